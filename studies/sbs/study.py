"""What the skull-base-surgery study adds to certiloop: its models and its generated kernels."""

from certiloop.models.library.registry import Study

HERE = "certiloop.studies.sbs"

STUDY = Study(
    name="sbs",
    title="Certifying the Safe Design of a Virtual Fixture Control Algorithm for a Surgical Robot",
    order=10,
    package=HERE,
    models={
        "sbs.ctrl1": f"{HERE}.models:ctrl1",
        "sbs.ctrl1_broken": f"{HERE}.models:ctrl1_broken",
        "sbs.immediate": f"{HERE}.models:immediate",
        "sbs.predictive": f"{HERE}.models:predictive",
        "sbs.predictive_multi": f"{HERE}.models:predictive_multi",
        "sbs.eqn12": f"{HERE}.models:eqn12",
        "sbs.ctrl2_2d": f"{HERE}.models:ctrl2_2d",
        "sbs.ctrl2": f"{HERE}.models:ctrl2",
        "sbs.ctrl2_dynamic": f"{HERE}.models:ctrl2_dynamic",
        "sbs.ctrl2_wrong_k": f"{HERE}.models:ctrl2_wrong_k",
        "sbs.ctrl2_last_wins": f"{HERE}.models:ctrl2_last_wins",
        "sbs.ctrl2_dynamic_join_anywhere": f"{HERE}.models:ctrl2_dynamic_join_anywhere",
    },
    generated={"sbs.ctrl2": ("generated/ctrl2.py", "generated/c")},
)
