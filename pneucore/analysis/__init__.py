"""Model against measurement: metrics, residual autocorrelation, comparison, calibration, diagnosis, history, reports."""
