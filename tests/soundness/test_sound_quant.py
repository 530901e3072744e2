from . import cases_quant
from .themes import theme_tests

outcomes, test_witness_confirms_label, test_engine_outcome_allowed, test_theme_shape = theme_tests(
    cases_quant, "7-quantifiers"
)
