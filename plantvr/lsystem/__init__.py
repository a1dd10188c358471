"""L-systems as a language (issue 23): L-Py grammars derived into module strings, interpreted by a turtle into the
shared tree arrays."""
from .modules import ModuleString

__all__ = ["ModuleString"]
