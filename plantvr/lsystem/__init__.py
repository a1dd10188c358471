"""L-systems as a language (issue 23): L-Py grammars derived into module strings, interpreted by a turtle into the
shared tree arrays."""
from .engine import LSystem, LSystemError
from .modules import ModuleString
from .turtle import LPY_UNSUPPORTED, TURTLE_MODULES, TurtleNodes, turtle, turtle_nodes

__all__ = ["LPY_UNSUPPORTED", "LSystem", "LSystemError", "ModuleString", "TURTLE_MODULES", "TurtleNodes", "turtle",
           "turtle_nodes"]
