from certiloop.cli.main import run

run()
