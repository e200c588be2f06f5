"""EKF SLAM with cones as landmarks and controlled loop closure (seed 000, section 5.3).

One room per concept of the seed:

- :mod:`~mapper.slam.ekf_slam`: :class:`EkfSlam`, the filter as the Mapper drives it: IMU
  prediction, wheel odometry, GPS, one LiDAR sweep, camera colours, the outputs.
- :mod:`~mapper.slam.models`: the motion and observation models (eqs. 5.1-5.4), the LiDAR noise.
- :mod:`~mapper.slam.ekf`: the predict and update numerics on the state and covariance.
- :mod:`~mapper.slam.association`: data association (gating, one global assignment per sweep).
- :mod:`~mapper.slam.preliminary`: the preliminary landmark list (5.3.3).
- :mod:`~mapper.slam.loop_closure`: controlled loop closure and the backward sweep (5.3.2).
- :mod:`~mapper.slam.landmarks`: what is known of each landmark besides its position.
- :mod:`~mapper.slam.blas`: the BLAS calls the update is made of.
"""
