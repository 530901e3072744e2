"""Extract a verified model's control step (or algorithm) into runtime Python.

What is extracted — "the control step" of the model's outer loop:
  * `{step; plant}*` whose plant is one ODE (a clock reset such as `t := 0` just before
    it belongs to the plant): the statements before the ODE (sbs.ctrl2, textbook.train);
  * `{plant; step}*`, a loop that runs its plant first (textbook.bouncing_ball): the
    statements after the ODE, applied to the state the plant reached;
  * `{step; mode1 ∪ mode2 ∪ ...}*` whose plant is a choice of ODEs, each with its evolution
    domain (sbs.ctrl1): the step and the choice of the mode; the function returns the rates
    `x_dot` the chosen mode gives the variables the modes set differently;
  * a program with no ODE at all (a Hoare triple such as cfmpa.builtdr): the whole program,
    an algorithm over integer-indexed arrays, with its `for` loops.

Two code shapes, each documented in the generated module's docstring:
  * a step over a family of boundaries (a `foreach`, or reads of families) is vectorised
    with numpy over the family, one mask per alternative of each choice (the shape of the
    shipped `studies/sbs/generated/ctrl2.py`);
  * everything else (scalar controllers, algorithms) is scalar Python with `if`/`elif`
    chains and `for` loops, one pass over a number kit (`certiloop.kernel.decide`): floats with
    a rigorous error bound, then exact rationals where a comparison is a near tie, so every
    decision is the real model's; a division by zero, a non-finite input or an output beyond
    the float range is "no run", never an exception.

Symbols that are keywords, C library names or look like generated names are renamed
`u_<name>` before generation (`names`).

Every generated module has the header MODEL, MODEL_HASH, INPUTS (scalar parameters),
FAMILIES (array parameters) and one entry function `controller(...)` returning
`(*outputs, enabled)`; its docstring names the outputs. The outputs are the values the step
computes that the plant (the ODE), the loop invariant or the guarantee read: the gain `k` of
ctrl2, the acceleration `a` of the train, the array `P` of builtDR. When the step computes no
such value but admits a command chosen elsewhere (`acc := *; ?acc >= 0`), the admitted
command is the output and the function is its check.

Code generation follows the syntax tree:
  * `x := e` becomes `x = <e>`; a family cell `u(i) := e` the array `u`; an array cell
    `P[k][i][j] := e` the assignment `P[k, i, j] = <e>`;
  * `x := *` at the top of the step is an input (a parameter) unless a later test pins it
    down by an equation: `tmp*G*X = 1` becomes the solved value guarded by the coefficient
    being non-zero (a zero divisor blocks that branch, exactly as in the model);
    `root*root*G = 2*d0*fnp` (quadratic) becomes its two roots, tried in turn; a family
    `F := *; ?∀j (F(j) <-> E(j))` becomes `F = E`;
  * a choice: the first enabled alternative, in the model's order, is taken. Any enabled
    alternative is a run of the model, so this deterministic choice is one of the runs the
    proof covers. Where no alternative is enabled the model has no run and the generated
    code says so (`enabled` is False): the caller must fall back. A choice nested in an
    alternative is flattened into paths (alternative, sub-alternative) in the same order;
  * a test outside a choice: `enabled` is False where it fails;
  * `?kt >= k; k := k  ∪  ?kt < k; k := kt` inside a `foreach` is the reduction
    k = min(k, min over the family's members of kt);
  * `for` loops (`i := lo; {?i < hi; body; i := i + 1}*; ?i >= hi`) become `for i in range(lo, hi)`.
Anything else is refused with a one-line ExtractError naming the statement and why.

With declared roles (`Theorem(roles=Roles(environment=(al,), controls=(a,)))`, `environment`):
the environment's `x := *` and the tests on them leave the step (the controller reads the chosen
values as inputs), a choice of plant modes becomes the controller's choice with each mode's
domain as a test, and the outputs are exactly the declared controls. Without roles nothing of
this runs.
Whether the model is proved is not checked here: the CLI refuses unproved models first.

The package, one job a module (no module imports one listed after it):
  * errors — ExtractError and the one-line refusal;
  * environment — declared roles: the environment's statements out of the step, the controls;
  * template — the generated module's header and docstrings, reserved names;
  * analysis — the control step of the model (`controller`), its outputs, shared syntax queries;
  * roots — solving a test's equation for the value it pins down;
  * shapes — small shapes the scalar code recognises (`{?true}*`, pins first, latches, ∀j);
  * vectorised — the numpy code over a family of boundaries;
  * scalar — the plain Python code (`if`/`elif`, `for` loops);
  * generate — `extract`: choose the shape, generate, name the model in every refusal;
  * names — the injective renaming of symbols the generated Python or C cannot use as they are;
  * shipped — the case studies' generated kernels (`shipped()`), `shipped_drift` and `regenerate`;
  * c/ (syntax, certified, family, scalar, emit) — `extract_c` (`--lang c`): the same walk
    written as C99 (a `for` loop over the boundaries for a family, `if`/`else if` chains for
    choices), every decision certified by the filter of `certified` (three-valued, UNDECIDED
    where the floats cannot decide);
  * c/build — tooling: compile a C kernel and call it through ctypes (tests, benchmarks);
  * monitor_terms — what the monitors share: MonitorError, a term as Python over a dict;
  * modelplex_family — the controller monitor of a step over a family of boundaries;
  * modelplex_environment — with declared roles, the environment monitor;
  * modelplex — `monitors(theorem)`: the ModelPlex-style controller and plant monitors of an
    extracted model, a module of their own (`certiloop extract MODEL --monitors`).
"""

from certiloop.kernel.extract.analysis import controller
from certiloop.kernel.extract.errors import ExtractError
from certiloop.kernel.extract.generate import extract
from certiloop.kernel.extract.shipped import shipped, shipped_drift

__all__ = ["ExtractError", "controller", "extract", "shipped", "shipped_drift"]
