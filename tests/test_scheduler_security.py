"""The local Dask cluster of `sarmotion track --processes` runs only its owner's code.

Finding: the scheduler listened on 127.0.0.1 without authentication, and another local
process connected and ran code in the workers. The cluster is now TLS with mutual
authentication from a certificate generated for it and held in memory only. The test
plays the other local process, with every credential it could have: none (plain TCP),
its own self-signed certificate, and a bare TLS handshake without a certificate; and,
as the control that shows the probe would notice, the same probe against an unsecured
cluster runs its code.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

distributed = pytest.importorskip("distributed")
pytest.importorskip("cryptography")

PROBE = textwrap.dedent(
    """
    import os, socket, ssl, sys
    from distributed import Client, Security

    address = sys.argv[1]
    host, port = address.split("://")[1].rsplit(":", 1)

    def attempt(label, addr, **kwargs):
        try:
            with Client(addr, timeout="10s", **kwargs) as client:
                pid = client.submit(os.getpid, pure=False).result(timeout=30)
            print("RAN", label, pid, flush=True)
        except Exception as exc:
            print("REFUSED", label, type(exc).__name__, flush=True)

    if address.startswith("tcp://"):
        attempt("plain", address)
    else:
        attempt("plain", "tcp://" + address.split("://")[1])
        attempt("own-certificate", address, security=Security.temporary())
        context = ssl.create_default_context()
        context.check_hostname = False
        context.verify_mode = ssl.CERT_NONE
        try:
            with socket.create_connection((host, int(port)), timeout=10) as raw:
                with context.wrap_socket(raw) as tls:
                    tls.sendall(b"\\0" * 64)
                    data = tls.recv(64)
            print("RAN" if data else "REFUSED", "no-certificate", flush=True)
        except (OSError, ssl.SSLError) as exc:
            print("REFUSED", "no-certificate", type(exc).__name__, flush=True)
    """
)


def _probe(address: str) -> list[str]:
    proc = subprocess.run(
        [sys.executable, "-c", PROBE, address], capture_output=True, text=True, timeout=240
    )
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.splitlines()


@pytest.mark.slow
def test_processes_cluster_refuses_a_client_without_its_certificate():
    from sarmotion.tracking.scale import local_cluster

    with local_cluster(1, processes=True) as cluster:
        address = cluster.scheduler_address
        assert address.startswith("tls://127.0.0.1:")
        with distributed.Client(cluster) as client:  # the owner runs code in its worker
            assert client.submit(os.getpid, pure=False).result(timeout=120) != os.getpid()
        lines = _probe(address)
    assert len(lines) == 3 and all(line.startswith("REFUSED") for line in lines), lines


@pytest.mark.slow
def test_the_probe_runs_code_in_an_unsecured_cluster():
    """Control: what the probe does to a scheduler without authentication."""
    with distributed.LocalCluster(
        n_workers=1,
        threads_per_worker=1,
        processes=False,
        protocol="tcp://",
        host="127.0.0.1",
        dashboard_address="127.0.0.1:0",
    ) as cluster:
        lines = _probe(cluster.scheduler_address)
    assert len(lines) == 1 and lines[0].startswith("RAN plain"), lines


def test_threads_cluster_has_no_network_listener_for_tasks():
    """Threads talk in memory (inproc://): nothing on the network carries tasks."""
    from sarmotion.tracking.scale import local_cluster

    with local_cluster(1, processes=False) as cluster:
        assert cluster.scheduler_address.startswith("inproc://")
        assert all(w.address.startswith("inproc://") for w in cluster.workers.values())
