"""The grid-free margin search of a rational loop in pole-zero form: its
levels, crossings, stationary points, peaks and their certificate."""
