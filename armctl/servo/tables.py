"""The servo control tables, under the servo package's name.

The tables are data that the config layer checks models against, so they live in the leaf
module :mod:`armctl.servo_tables`; this module re-exports them.
"""

from __future__ import annotations

from armctl.servo_tables import (
    RPM_UNIT,
    TABLES,
    VENDORS,
    Access,
    Alarm,
    ControlTable,
    Encoding,
    Family,
    Register,
    RegisterSpec,
    Vendor,
    alarms_from_bits,
    table_for,
    table_for_model_number,
)

__all__ = [
    "RPM_UNIT",
    "TABLES",
    "VENDORS",
    "Access",
    "Alarm",
    "ControlTable",
    "Encoding",
    "Family",
    "Register",
    "RegisterSpec",
    "Vendor",
    "alarms_from_bits",
    "table_for",
    "table_for_model_number",
]
