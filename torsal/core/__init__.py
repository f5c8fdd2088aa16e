"""Leaf helpers every layer may use: atomic writes, the one unit table, the base error class.

Imports nothing from the rest of torsal.
"""
from .atomic import atomic_path, write_json
from .errors import TorsalError
from .inputs import InputFileError, MissingInputError, check_input, read_input
from .outputs import OutputFolderError, output_folder
from .units import INSUNITS, UNIT_TO_M, UNIT_TO_MM, UNITS, scale

__all__ = ["atomic_path", "write_json", "TorsalError", "InputFileError", "MissingInputError", "check_input",
           "read_input", "OutputFolderError", "output_folder", "UNIT_TO_MM", "UNIT_TO_M", "INSUNITS",
           "UNITS", "scale"]
