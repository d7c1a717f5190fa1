"""Research tools: what re-measures the project's claims, outside the wheel (`pip install .` does not ship it).

Run from a checkout, with the project installed (`make install`): `python -m research COMMAND` (`--help` lists
them). `reproduce`: the thesis' quantitative claims re-measured on the reference drivers, written as
docs/thesis-reproduction.md. The top layer (tests/test_layers.py): it may import every package of the product,
and none imports it.
"""
