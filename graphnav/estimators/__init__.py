"""The estimators: strapdown INS, the error-state EKF, the factor graph, and the streaming Navigator over them."""
