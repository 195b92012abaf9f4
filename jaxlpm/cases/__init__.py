"""Paper reproductions: one module per paper (its data, published numbers and reproduction),
and jaxlpm's own cases (`approach`)."""

from . import approach, duan, jiang2011, mei2010, tan2011, yue2016

CASES = {mei2010.NAME: mei2010, jiang2011.NAME: jiang2011, duan.NAME: duan,
         yue2016.NAME: yue2016, tan2011.NAME: tan2011,
         approach.NAME: approach}

__all__ = ["CASES"]
