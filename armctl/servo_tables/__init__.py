"""Servo control tables as data: one :class:`ControlTable` per supported model.

A leaf package (it imports nothing from armctl but the error types), so that the config layer
can check servo models against it. Each family's module holds its tables and its
:class:`Vendor` description (ticks, units, homing offset convention, EEPROM lock, operating
modes, baud codes), which code above asks instead of testing for a vendor:

* :mod:`.dynamixel`: Dynamixel X series (XL330-M077, XL330-M288, XL430-W250, XM430-W350,
  XM540-W270).
* :mod:`.feetech`: Feetech STS3215.

A table lists every item of the maker's table (:attr:`ControlTable.items`, indexed items such
as Indirect Data 5 included); :attr:`ControlTable.registers` holds the non-indexed ones by
:class:`Register`.

Negative values are two's complement on Dynamixel and sign-magnitude (one sign bit) on Feetech;
:class:`Encoding` records which, per register.
"""

from __future__ import annotations

from armctl.errors import UnknownNameError
from armctl.servo_tables import dynamixel, feetech
from armctl.servo_tables.common import (
    Access,
    Alarm,
    ControlTable,
    Encoding,
    Family,
    IndirectBlock,
    Register,
    RegisterSpec,
    Vendor,
    alarms_from_bits,
)
from armctl.servo_tables.dynamixel import RPM_UNIT

__all__ = [
    "RPM_UNIT",
    "TABLES",
    "VENDORS",
    "Access",
    "Alarm",
    "ControlTable",
    "Encoding",
    "Family",
    "IndirectBlock",
    "Register",
    "RegisterSpec",
    "Vendor",
    "alarms_from_bits",
    "table_for",
    "table_for_model_number",
]

#: Each family's conventions.
VENDORS: dict[Family, Vendor] = {Family.DYNAMIXEL: dynamixel.VENDOR,
                                 Family.FEETECH: feetech.VENDOR}

#: Every supported model's table, by lower-case model name.
TABLES: dict[str, ControlTable] = {**feetech.TABLES, **dynamixel.TABLES}


def table_for(model: str) -> ControlTable:
    """The control table of a model name (case-insensitive).

    Raises:
        UnknownNameError: For a model armctl does not know.
    """
    try:
        return TABLES[model.lower()]
    except KeyError:
        raise UnknownNameError("servo model", model, list(TABLES)) from None


def table_for_model_number(family: Family, number: int) -> ControlTable | None:
    """The table whose model number is ``number`` in ``family``, or ``None``."""
    for table in TABLES.values():
        if table.family is family and table.model_number == number:
            return table
    return None
