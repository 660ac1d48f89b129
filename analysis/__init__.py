"""Signal processing on arrays: spectra, harmonics, FRF, modal identification, EM-vs-FEM comparison, plots."""
