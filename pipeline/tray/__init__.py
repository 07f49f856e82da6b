"""Several models, one job: the tray file, its layout, parts, plan, mesh and build."""
