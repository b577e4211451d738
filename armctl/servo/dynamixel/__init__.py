"""Dynamixel: what is particular to the family's protocols (2.0 and 1.0) above the tables.

The control tables themselves are data in :mod:`armctl.servo_tables.dynamixel`; this package
owns the protocol behaviour a servo of the family shows on the wire (how it reports errors,
which instructions it knows, how it checks a write) and the adapter over ``dynamixel_sdk``.
"""
