"""Pictures of a result: the previews of a build folder, the thickness picture."""
