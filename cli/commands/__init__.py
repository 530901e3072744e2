"""One module per `certiloop` command, each with `add_parser(subparsers)` and `run(args) -> exit code`."""
