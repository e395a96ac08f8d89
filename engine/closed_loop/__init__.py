"""The closed loop: its poles polished on the characteristic equation, root
loci, time responses and their measures."""
