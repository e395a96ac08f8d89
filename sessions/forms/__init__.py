"""The one-line text forms of the edit dialogs and of every transfer kind, each
a parse/format pair."""
