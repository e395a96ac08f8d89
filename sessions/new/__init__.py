"""New sessions: the templates, the kinds of new session, plants imported from
.mat and .npz files."""
