"""The set-up (scripts/setup.sh) provides what the README promises."""

import h5py


def test_h5py_is_built_against_parallel_hdf5():
    # Required by the engine issue for the distributed engine's collective output; the PyPI
    # wheel has no mpio driver, so this fails if setup.sh installed the wheel instead.
    assert h5py.get_config().mpi
    assert "mpio" in h5py.registered_drivers()
