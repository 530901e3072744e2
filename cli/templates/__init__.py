"""The files `certiloop init` writes into a new project (read with importlib.resources)."""
