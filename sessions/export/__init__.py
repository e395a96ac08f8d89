"""A design exported: python-control and MATLAB scripts, JSON and CSV data,
from one design model."""
