"""Feetech: what is particular to the SCS/STS protocol above the tables.

The control tables themselves are data in :mod:`armctl.servo_tables.feetech`; this package
owns the protocol behaviour a servo of the family shows on the wire (a status byte of alarm
bits, silence on bad requests, the EEPROM lock) and the adapter over ``scservo_sdk``.
"""
