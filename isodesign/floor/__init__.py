"""The floor: one-third-octave bands, units, vibration criteria and floor spectra."""
