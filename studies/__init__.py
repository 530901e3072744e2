"""The case studies: one package per paper, each with its models, simulators, searches, runtime,
generated code and plots, registered with certiloop through `certiloop.models.library.registry`
(entry points `certiloop.studies` in pyproject.toml). Nothing generic imports them."""
