"""Conversions between recordings and the formats other tools use: UFF 58 (modal software),
TDMS (NI-DAQmx and LabVIEW logs) and SEP005 channel dictionaries (SDyPy, pyFRF)."""
