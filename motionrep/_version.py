"""motionrep's version, in a module of its own: modules that write it into files (``.mrc``, glTF, the viewer's
page) or show it import it from here, never from the package's front door (``motionrep/__init__.py``, which
imports the library lazily), so no import runs up to the front door and back down."""

__version__ = "0.1.0"
