"""What the workbench's screens show, free of widgets: the open session
(`Workbench`), views, edits and their history, the rows of the tables, the
tableau's text."""
