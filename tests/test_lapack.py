"""The leading eigenpairs through scipy's Cython LAPACK are scipy.linalg.eigh's, number for
number (same driver, same arguments), and the kernels' package loads no scipy.linalg."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
import scipy.linalg

from streamseg._kernels.lapack import leading_eigh


@pytest.mark.parametrize("n,k", [(1, 1), (2, 1), (5, 2), (30, 5), (141, 7), (400, 4), (12, 12)])
def test_same_numbers_as_scipy_eigh_with_a_subset(n, k):
    rng = np.random.default_rng(n * 100 + k)
    a = rng.random((n, n))
    a = a + a.T
    w, v = leading_eigh(a, k)
    w_ref, v_ref = scipy.linalg.eigh(a, subset_by_index=[n - k, n - 1])
    assert w.shape == (k,) and v.shape == (n, k)
    np.testing.assert_array_equal(w, w_ref)
    np.testing.assert_array_equal(v, v_ref)


def test_repeated_eigenvalues_and_a_c_ordered_input_read_by_its_lower_triangle():
    a = np.kron(np.eye(3), np.ones((4, 4)))  # eigenvalue 4 three times
    upper_noise = np.triu(np.full_like(a, 7.0), 1)
    w, v = leading_eigh(a + upper_noise, 3)  # the upper triangle is not read
    np.testing.assert_allclose(w, [4.0, 4.0, 4.0])
    np.testing.assert_allclose(v.T @ v, np.eye(3), atol=1e-12)
    w_ref, v_ref = scipy.linalg.eigh(a + upper_noise, subset_by_index=[9, 11])
    np.testing.assert_array_equal(v, v_ref)


@pytest.mark.parametrize("bad", [np.ones((3, 4)), np.array([[1.0, np.nan], [np.nan, 1.0]])])
def test_bad_input_is_refused(bad):
    with pytest.raises(ValueError):
        leading_eigh(bad, 1)


def test_kernels_load_numba_without_scipy_linalg():
    """numba's start-up BLAS check is met by the one extension module it asks for."""
    probe = (
        "import json, sys, numpy as np\n"
        "from streamseg._kernels.kmeans import lloyd\n"
        "from streamseg._kernels.lapack import leading_eigh\n"
        "lloyd(np.zeros((4, 2)), np.zeros((2, 2)), 5)\n"
        "leading_eigh(np.eye(3), 2)\n"
        "import numba.np.arraymath as am\n"
        "print(json.dumps([am._HAVE_BLAS, sorted(sys.modules)]))\n"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    have_blas, loaded = json.loads(out.stdout)
    assert have_blas
    assert "scipy.linalg.cython_blas" in loaded
    assert "scipy.linalg" not in loaded


def test_scipy_linalg_imports_as_usual_after_the_kernels():
    probe = (
        "import numpy as np\n"
        "import streamseg._kernels\n"
        "import scipy.linalg\n"
        "from scipy.linalg import cython_blas, cython_lapack\n"
        "import scipy.linalg.cython_blas as cb\n"
        "assert cb is cython_blas\n"
        "print(scipy.linalg.eigh(np.eye(2))[0].tolist())\n"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[1.0, 1.0]"
