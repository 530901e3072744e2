from certiloop.proofs.cli.main import run

run()
