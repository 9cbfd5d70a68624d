"""Qt-free view models: what the windows draw (the skeleton's figure, the camera, the plots'
scales, the magnetometer calibration's picture), computed without a widget so it can be tested."""
