"""The dual-arm SCARA collision-free motion planner verified in HOL4: the `cfmpa.*` models (builtDR,
geometry, paths, motion), the arms' swept regions, the planner, and the generated algorithms."""
