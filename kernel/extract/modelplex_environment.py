"""The environment monitor of a model with declared roles (`Roles(environment=(al,), ...)`):
`environment_monitor(state) -> bool`, True iff the environment's values in `state` satisfy
every assumption the model makes about the environment's choices — the tests that constrain
its `x := *` (`-B <= al & al <= A`), in the model's order — so a runtime can tell when the
world leaves the model (the proof says nothing about such a step).

Decided as the controller monitor decides (`certiloop.kernel.decide`): floats with a rigorous
error bound, exact rationals where the bound cannot decide; a non-finite value, a division by
zero, or a value the exact pass cannot represent is False. So an assumption is never reported
as held where the reals say it fails."""

from __future__ import annotations

from certiloop.kernel.extract.analysis import Step
from certiloop.kernel.extract.errors import ExtractError
from certiloop.kernel.extract.monitor_terms import MonitorError, numpy_conversion, theorem_symbols
from certiloop.kernel.extract.scalar import KIT, Python
from certiloop.models.lang.programs import Havoc, Seq, Test
from certiloop.models.lang.terms import BOOL, INT, REAL, Node
from certiloop.models.lang.theorem import Theorem


def environment_monitor(theorem: Theorem, step: Step) -> tuple[list[str], str, str]:
    """(the keys the monitor reads: the environment's variables, then the state its tests read;
    the module header's lines about them; the source of `environment_monitor` and its one pass
    over the number kit)."""
    tests = [q for q in step.environment if isinstance(q, Test)]
    chosen = list(dict.fromkeys(q.target.payload for q in step.environment if isinstance(q, Havoc)))
    symbols = theorem_symbols(theorem)
    py = Python(symbols, set(), Seq(tuple(tests)) if tests else Test(Node("true", (), BOOL)))
    py.kit = KIT
    try:
        py.block(tests)
    except ExtractError as exc:
        raise MonitorError(f"no environment monitor: {exc}") from None
    state = chosen + [v for v in py.params if v not in chosen]
    assumptions = " & ".join(str(q.cond) for q in tests) or "none (any finite value)"
    lines = ["def environment_monitor(state):",
             '    """True iff the values in `state` (a dict with the keys ENVIRONMENT_STATE) satisfy the',
             "    model's assumptions about the environment's choices, decided for the real numbers these",
             "    floats are (exact rationals where the float bound cannot decide). A non-finite value is",
             '    False. ENVIRONMENT_ASSUMPTIONS lists what is checked."""',
             "    return _decide.run(_environment_monitor, False, state)",
             "",
             "",
             f"def _environment_monitor({KIT}, state):"]
    for v in state:
        sort = symbols[v].sort
        if sort in (INT, BOOL):  # exactly an integer (a truth value): 1.5 is no Int
            lines += [f"    {v} = _exact(state[{v!r}], {'int' if sort == INT else 'bool'})",
                      f"    if {v} is None:",
                      "        return False"]
        else:
            conv = f"{KIT}.real" if sort == REAL else numpy_conversion(sort)
            lines.append(f"    {v} = {conv}(state[{v!r}])")
    lines.append("    with np.errstate(divide='ignore', invalid='ignore', over='ignore'):")
    lines += [text.replace("return __BLOCKED__", "return False") for text in py.lines] or ["        pass"]
    lines.append("    return True")
    header = (f"ENVIRONMENT = {chosen!r}  # the values the environment chooses (sensed by the controller)\n"
              f"ENVIRONMENT_STATE = {state!r}  # environment_monitor's keys\n"
              f"ENVIRONMENT_ASSUMPTIONS = {assumptions!r}\n")
    return state, header, "\n".join(lines) + "\n"
