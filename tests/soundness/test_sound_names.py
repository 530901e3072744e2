from . import cases_names
from .themes import theme_tests

outcomes, test_witness_confirms_label, test_engine_outcome_allowed, test_theme_shape = theme_tests(
    cases_names, "5-names"
)
