"""Wave-optics post-processing of traced rays (pure NumPy/SciPy, no kernels): the diffraction PSF."""
