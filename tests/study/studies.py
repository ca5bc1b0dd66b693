"""Study-file fragments shared by the study tests."""

SENSORS_BY_ESTIMATOR = """
[[axes]]
name = "sensors"
labels = ["speed", "speed+yaw"]
values = [{}, { "sensors.yaw_rate_sigma" = 0.01 }]
[[axes]]
name = "estimator"
key = "estimator.kind"
values = ["ekf", "ukf"]
[[analysis.findings]]
metric = "abs_radius_final_error_L"
axis = "sensors"
baseline = "speed"
unit = "m"
"""
"""Two axes (speed / speed + yaw rate × EKF / UKF: four combinations) and the finding on the final
left-radius error by sensing; appended after a study's ``[base]`` table."""

NO_FIGURES = """
[analysis]
figures = false
"""
"""Appended to a study whose test reads its rows or tables, not its figures: the summary is written
without drawing (the figure code is checked by the tests that read the figures)."""
