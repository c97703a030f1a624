"""Algorithm core: pure numpy/OpenCV, no rclpy import anywhere below this package."""
