"""The reference encoder (sans-IO): configuration, the checker and a conforming device model.

``Checker`` judges captured cycles against behaviour.md §9; ``ReferenceEncoder`` answers
setpoints like a conforming device (used by the simulator). See docs/encoder_api.md.
"""
from .config import EncoderConfig, next_ls
from ._state import Checker
from .model import ReferenceEncoder
from . import position

__all__ = ["EncoderConfig", "Checker", "ReferenceEncoder", "position", "next_ls"]
