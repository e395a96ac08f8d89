"""Numerical building blocks: polynomials and their ratios, zeros of sums of
simple fractions, bracketed and vectorized root refinement, rational (AAA)
fits of frequency responses."""
