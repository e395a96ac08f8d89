"""The design report: content as plain blocks, matplotlib figures, HTML and
Markdown rendering."""
