"""Runtime support for extracted code (float-sound arithmetic: `filtered`) and the extraction tool
(`extract/`). The kernels themselves belong to their case studies (`certiloop.studies.*`)."""
