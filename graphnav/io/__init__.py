"""Reading and writing: the real data sets and vehicle formats (CSV, ROS 2 bags, PD0, JSON-lines) and the outputs."""
