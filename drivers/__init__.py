"""Hardware contracts and backends: NI-DAQmx, VISA signal source, simulated rig."""
