"""The generator of the shared test vectors, one module per vector file (tests/vectors/make_vectors.py runs
them); `common` and `shapes` hold what several of them build on."""
