"""`python -m research reproduce`: the thesis' quantitative claims, re-measured on the reference drivers.

One module per group of claims (`stiffness`, `viscosity`, `equations`, `gestures`, `classifier`,
`timings`); each returns `Group`s of `Claim` records (`claim.py`), which `report.py` writes to
docs/thesis-reproduction.md with the comparison plots (`plots.py`). `command.py` is the subcommand.
"""
