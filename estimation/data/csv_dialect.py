"""How a CSV file other tools wrote is laid out: Excel's UTF-8 byte-order mark, ``,`` ``;``
or tab between fields, and with ``;`` or tab a decimal comma (``0,25``). One reader for
every table the project imports (runs, thrust-stand tables, notebooks' CSVs).

    >>> dialect = sniff_dialect(["t;position", "0,0;0,000", "0,1;0,012"])
    >>> dialect.delimiter, dialect.number("0,012")
    (';', 0.012)
"""

from __future__ import annotations

import csv
from collections.abc import Iterable
from dataclasses import dataclass

#: Lines the separator is guessed from.
SNIFF_LINES = 20
#: A line starting with this is a comment (an export's units and run description).
COMMENT = "#"
BOM = "\ufeff"


@dataclass(frozen=True)
class TableDialect:
    """The separator, and whether numbers use a decimal comma (only with ``;`` or tab: a
    comma cannot be both)."""

    delimiter: str = ","

    @property
    def decimal_comma(self) -> bool:
        return self.delimiter != ","

    def number(self, cell: str) -> float:
        """``cell`` as a float (``ValueError`` when it is not a number): blanks and
        non-breaking spaces dropped, a decimal comma read as a point."""
        text = cell.strip().replace("\u00a0", "").replace(" ", "")
        return float(text.replace(",", ".") if self.decimal_comma else text)


#: The plain comma-separated table with decimal points.
COMMA = TableDialect()


def sniff_dialect(lines: Iterable[str]) -> TableDialect:
    """The dialect of a table from its first non-comment lines (``,`` when unsure)."""
    sample = []
    for line in lines:
        if line.strip() and not line.lstrip().startswith(COMMENT):
            sample.append(line.removeprefix(BOM).rstrip("\r\n"))
        if len(sample) >= SNIFF_LINES:
            break
    try:
        return TableDialect(csv.Sniffer().sniff("\n".join(sample), delimiters=",;\t").delimiter)
    except csv.Error:
        return COMMA


def decode_table(data: bytes) -> str:
    """UTF-8 text without a byte-order mark; ``ValueError`` naming the byte that is not."""
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise ValueError(f"file: not UTF-8 text ({err.reason} at byte {err.start})") from None
