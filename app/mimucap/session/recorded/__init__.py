"""A recorded session: reviewed, processed again, analysed, tested, exported and compared, with
the calibrations it is computed with and what every output says of its provenance."""
