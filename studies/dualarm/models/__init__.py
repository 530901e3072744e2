"""The dual-arm planner's models: builtDR as a Hoare triple, the convex-polygon geometry, paths
through the state database, and executing a plan."""
