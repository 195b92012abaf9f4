"""Paper reproductions: one module per paper (its data, published numbers and reproduction)."""

from . import duan, jiang2011, mei2010, tan2011

CASES = {mei2010.NAME: mei2010, jiang2011.NAME: jiang2011, duan.NAME: duan,
         tan2011.NAME: tan2011}

__all__ = ["CASES"]
