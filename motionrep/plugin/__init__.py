"""The plugin seam: the hooks, the registry, and the interfaces a codec or representation implements.

Above the model (it uses the pose model and FK) and below the file formats, which ask the registry for a
codec or representation by name.  The conformance suite for plugin authors is :mod:`motionrep.testing`, above
every wing because it exercises them all."""
