"""The configuration's core: the sections of one parameter file and the rules between them."""
