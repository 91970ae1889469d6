"""CalculiX (``ccx``) result readers: ``.frd`` result files and ``.dat`` print files."""

from farm.ccx.dat import DatBlock, block_times, read_dat, select_blocks
from farm.ccx.frd import FrdFile, FrdResult, read_frd

__all__ = [
    "DatBlock",
    "FrdFile",
    "FrdResult",
    "block_times",
    "read_dat",
    "read_frd",
    "select_blocks",
]
