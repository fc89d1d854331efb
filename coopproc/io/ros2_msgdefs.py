"""ROS 2 message definitions (``ros2msg`` text with dependencies) that coopproc writes.

``nav_msgs/msg/Odometry`` and ``sensor_msgs/msg/NavSatFix`` are the standard ones;
``coopproc_msgs/msg/UwbRange`` is coopproc's own range message (any message with two id
fields and a range field can be read instead, mapped in ``session.toml [mcap]``).
"""

from __future__ import annotations

__all__ = ["IMU", "NAVSATFIX", "ODOMETRY", "UWB_RANGE", "UWB_RANGE_MAPPING"]

_SEP = "=" * 80 + "\n"

_HEADER = (
    _SEP
    + "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n"
    + _SEP
    + "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
)

#: nav_msgs/msg/Odometry and its dependencies.
ODOMETRY = (
    "std_msgs/Header header\n"
    "string child_frame_id\n"
    "geometry_msgs/PoseWithCovariance pose\n"
    "geometry_msgs/TwistWithCovariance twist\n"
    + _HEADER
    + _SEP
    + "MSG: geometry_msgs/PoseWithCovariance\nPose pose\nfloat64[36] covariance\n"
    + _SEP
    + "MSG: geometry_msgs/Pose\nPoint position\nQuaternion orientation\n"
    + _SEP
    + "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n"
    + _SEP
    + "MSG: geometry_msgs/Quaternion\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w\n"
    + _SEP
    + "MSG: geometry_msgs/TwistWithCovariance\nTwist twist\nfloat64[36] covariance\n"
    + _SEP
    + "MSG: geometry_msgs/Twist\nVector3 linear\nVector3 angular\n"
    + _SEP
    + "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n"
)

#: sensor_msgs/msg/NavSatFix and its dependencies.
NAVSATFIX = (
    "std_msgs/Header header\n"
    "sensor_msgs/NavSatStatus status\n"
    "float64 latitude\n"
    "float64 longitude\n"
    "float64 altitude\n"
    "float64[9] position_covariance\n"
    "uint8 position_covariance_type\n"
    + _HEADER
    + _SEP
    + "MSG: sensor_msgs/NavSatStatus\nint8 status\nuint16 service\n"
)

#: sensor_msgs/msg/Imu and its dependencies.
IMU = (
    "std_msgs/Header header\n"
    "geometry_msgs/Quaternion orientation\n"
    "float64[9] orientation_covariance\n"
    "geometry_msgs/Vector3 angular_velocity\n"
    "float64[9] angular_velocity_covariance\n"
    "geometry_msgs/Vector3 linear_acceleration\n"
    "float64[9] linear_acceleration_covariance\n"
    + _HEADER
    + _SEP
    + "MSG: geometry_msgs/Quaternion\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w\n"
    + _SEP
    + "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n"
)

#: coopproc_msgs/msg/UwbRange.
UWB_RANGE = (
    "std_msgs/Header header\nstring from_id\nstring to_id\nfloat64 range\nfloat64 sigma\n" + _HEADER
)

#: The ``[mcap]`` field mapping of :data:`UWB_RANGE`.
UWB_RANGE_MAPPING = {"from_field": "from_id", "to_field": "to_id", "range_field": "range"}
