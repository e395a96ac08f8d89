"""The Workbench's parts, each with one job: the records and their undo (`records`), the
session's file (`persistence`)."""
