#!/usr/bin/env python3
"""The peer of the sparse benchmark: scipy.sparse.linalg.eigsh on the matrices
`modal analyze --export-matrices DIR` wrote.

    python3 bench/scipy_eigsh.py DIR K SIGMA TOL

Reads DIR/K.mtx and DIR/M.mtx, solves K phi = lambda M phi for the K
eigenvalues nearest SIGMA in shift-invert mode (eigsh(K, k, M, sigma, tol),
which factors K - sigma M with SuperLU), and prints
    read_s <seconds to read both files>
    eigsh_s <seconds in eigsh>
    lambda <eigenvalue>        (one line each, ascending)
"""
import sys
import time

import numpy as np
import scipy.io
import scipy.sparse.linalg


def main():
    directory, k, sigma, tol = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
    t0 = time.perf_counter()
    K = scipy.io.mmread(f"{directory}/K.mtx").tocsc()
    M = scipy.io.mmread(f"{directory}/M.mtx").tocsc()
    t1 = time.perf_counter()
    values = scipy.sparse.linalg.eigsh(K, k=k, M=M, sigma=sigma, which="LM", tol=tol, return_eigenvectors=False)
    t2 = time.perf_counter()
    print(f"read_s {t1 - t0:.6f}")
    print(f"eigsh_s {t2 - t1:.6f}")
    for v in np.sort(values):
        print(f"lambda {v:.17g}")


if __name__ == "__main__":
    main()
