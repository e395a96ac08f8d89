"""Bundled example sessions, their data tables, and the script that makes the launch-vehicle ones."""
