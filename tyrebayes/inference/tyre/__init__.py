"""The per-tyre model: windowed observations, tyre-curve likelihood, MAP + Laplace and NUTS fits.

``data`` turns features into windowed observations; ``model`` is the NumPyro model (thesis
eq. 3.3 slip and force, Magic Formula / brush curves); ``laplace`` and ``nuts`` the two engines;
``predictive`` the per-window log-likelihood and predictive draws; ``adequacy`` and
``window_correlation`` the model checks; ``fit`` the entry point returning a ``result.TyreFit``.
"""
