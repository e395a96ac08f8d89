"""Blocks of several signals: a state space with m inputs and m outputs as one block of a
block diagram (`state_space_ports`)."""
