"""The batch simulator: many runs of a hybrid program at once (numpy), for the falsifier's batch phase."""
