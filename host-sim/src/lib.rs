//! flexcal-sim: the desktop side of flexcal (simulator, recordings, calibrator, reports).
