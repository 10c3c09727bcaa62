"""Layer 2 of the diagnosis: the fitting problem.

The scales and signals the hypotheses need (``context``) and the weighted
residuals of a lab state against the data, with the noise limits and the
model-error floor (``residuals``). Above the data; knows no hypothesis.
"""
