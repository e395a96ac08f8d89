"""Margins of an open loop and the closed-loop peaks: the searches (grid-free
in pole-zero form, and on a detection grid), their notes, disk margins, Ms,
Mt, |KS| and the delay margin."""
