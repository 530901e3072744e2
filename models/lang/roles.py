"""Who chooses what in a control loop: `Roles(environment=(al,), controls=(a,))` on a Theorem.

The environment's variables are the values the world picks and the robot senses (a leader's
acceleration `al := *; ?-B <= al & al <= A`); the controls are what the robot computes and
actuates (its own acceleration `a`); every other symbol is state. The declaration does not change
the claim the proof is about: it tells `certiloop extract` where the controller ends (see
`certiloop.kernel.extract.environment`). Checked here: each entry is a plain symbol, named once."""

from __future__ import annotations

from dataclasses import dataclass

from certiloop.models.lang.terms import ModelError, Node


@dataclass(frozen=True, eq=False)
class Roles:
    """environment: symbols the environment chooses (sensed inputs of the controller);
    controls: symbols the controller chooses (its outputs, the actuation)."""

    environment: tuple[Node, ...] = ()
    controls: tuple[Node, ...] = ()

    def __post_init__(self) -> None:
        for field in ("environment", "controls"):
            value = getattr(self, field)
            if isinstance(value, Node):  # Roles(environment=al): one symbol
                value = (value,)
            object.__setattr__(self, field, tuple(value))

    @property
    def environment_names(self) -> tuple[str, ...]:
        return tuple(v.payload for v in self.environment)

    @property
    def control_names(self) -> tuple[str, ...]:
        return tuple(v.payload for v in self.controls)

    @property
    def key(self) -> tuple:
        """What the theorem's canonical text records (the symbols with their sorts)."""
        return (tuple(v.key for v in self.environment), tuple(v.key for v in self.controls))


def check_roles(roles: object, where: str) -> None:
    """One line naming the entry and the fix when the declaration is not a list of symbols."""
    if not isinstance(roles, Roles):
        raise ModelError(f"{where}: roles must be Roles(environment=(...), controls=(...)), got "
                         f"{type(roles).__name__}")
    seen: dict[str, str] = {}
    for field in ("environment", "controls"):
        for v in getattr(roles, field):
            if not isinstance(v, Node) or v.op != "var":
                raise ModelError(f"{where}: roles {field} must be symbols (from Reals(...)), got `{v}`")
            if v.sort.is_array:
                raise ModelError(f"{where}: roles {field} names the array `{v.payload}`; only scalar "
                                 "symbols have a role")
            if v.payload in seen:
                what = "twice" if seen[v.payload] == field else f"in both {seen[v.payload]} and {field}"
                raise ModelError(f"{where}: roles name `{v.payload}` {what}; give each symbol one role")
            seen[v.payload] = field
    if not roles.controls:
        raise ModelError(f"{where}: roles declare no controls; name the values the controller computes "
                         "(controls=(a,))")
