"""Transfer models: the safe expression parser and its folding, blocks
(rational, tabulated, delay), an expression's factored form,
interconnections (block diagrams and COEBRA's matrix format), compensators,
the z-w bilinear map."""
