"""The humanoid's physical twin: the HRP-2-class robot of a humanoid library's URDF in MuJoCo, on
flat soles, with position-servoed joints, ankle force/torque sensors and a waist IMU."""
