"""The EKF-SLAM filter's parts, one job a module; ``ekf_slam.EkfSlam`` composes them into one class.

kernels.py: small maths and BLAS/LAPACK helpers of the hot path; motion.py: the two motion models'
predicts and the pose's process noise; corrections.py: the innovation and the Joseph-form
corrections (landmark, Schmidt, yaw, position); nis.py: association scores (NIS against every
landmark, joint NIS); batch.py: a whole frame as one joint update (tests and benchmarks only);
map_edits.py: landmarks added, named and removed. The parts are mixins on one state (the mean and
covariance buffers of EkfSlam): the names with a leading underscore are the filter's own.
"""
