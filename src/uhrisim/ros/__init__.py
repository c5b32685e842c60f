"""The ROS translation: uhrisim's products as ROS 2 messages, below both of their outputs.

One function per message (:mod:`.messages`, :mod:`.markers`), one place for every name
(:mod:`.topics`: topics, types, QoS kinds, frames), the frame conversions NED/FRD ->
ENU/FLU (:mod:`.convert`), the CDR encoding (:mod:`.cdr`) and the message definitions
(:mod:`.msgdefs`, :mod:`.uhrisim_msgs`). Two outputs use it and nothing else: the
recording writes its bytes to an MCAP file (:mod:`uhrisim.record`), the live bridge
hands the same bytes to DDS (:mod:`uhrisim.bridges.ros2`), so a recorded topic and a
live one are equal by construction. No rclpy here: the package imports without ROS.
"""
