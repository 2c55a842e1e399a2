"""Post-processors for CAM systems that write programs postproc then compensates."""
