"""The toolbox beside the paper's method: what contact.engineering and Gwyddion users know.

The method (G, its errors and fits, spectra, the contact theories, quality, units and the
archive) is the package's centre; these modules compute what its users also expect of a
topography and that the method does not need: the power spectrum from heights
(:mod:`.psd`), ISO 25178 / 4287 parameters, distributions and scale-dependent slope and
curvature (:mod:`.parameters`), Fourier band filters (:mod:`.filters`), the variable
bandwidth analysis (:mod:`.bandwidth`) and the sensitivity of G to the cleaning
(:mod:`.cleaning`). They import from the centre, never the other way round; their public
functions are in the ``xrough`` namespace and on the ``.rough`` accessor.
"""
