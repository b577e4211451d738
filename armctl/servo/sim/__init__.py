"""The wire-level simulated servo bus (Dynamixel 2.0 and Feetech on a pseudo-terminal)."""
