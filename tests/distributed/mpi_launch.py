"""Launching commands for the distributed tests, mpirun with a session directory of its own.

ctest runs these tests two at a time, so two mpirun processes often start in
the same instant. OpenMPI 4.1's runtime (ORTE) makes its session directories
under one base shared by all of a user's jobs (/tmp/ompi.HOST.UID); two
launchers making them together can fail before any rank starts ("ORTE_ERROR_LOG:
Error in file ../../../orte/util/session_dir.c at line 107": the clean-clone
CI of b0e6f5d, distributed_free_lattice_np1; OpenMPI's issue 8510 describes
the same under CTest). Each mpirun here gets a fresh base of its own
(MCA parameter orte_tmpdir_base), removed when it ends.
"""
import os
import subprocess
import tempfile

MPIRUN = ["mpirun", "--quiet", "--allow-run-as-root", "--oversubscribe", "-np"]


def run(command, timeout):
    """subprocess.run(command), output captured as text; an mpirun command
    runs with its own session directory base."""
    if command[:1] != ["mpirun"]:
        return subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    # (ignore_cleanup_errors: ranks a timeout left running may still write there)
    with tempfile.TemporaryDirectory(prefix="modal-ompi-", ignore_cleanup_errors=True) as base:
        environment = dict(os.environ, OMPI_MCA_orte_tmpdir_base=base)
        return subprocess.run(command, capture_output=True, text=True, timeout=timeout, env=environment)
