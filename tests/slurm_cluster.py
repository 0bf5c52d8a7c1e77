"""A private single-node SLURM cluster (munged, slurmctld, slurmd) for the job script tests.

Everything lives in one new temporary directory: slurm.conf, the munge key, socket, pid and log
files, the state and spool directories. The daemons listen on free ports picked at start, so a
system SLURM on the same machine (ports 6817/6818, /run/munge) is neither used nor disturbed.
Clients find the cluster through ``SLURM_CONF`` (:attr:`SlurmCluster.env`, exported into
``os.environ`` by :func:`cluster` while it runs) and munge through ``AuthInfo=socket=...``.

Requirements: root (slurmd must be root to start job steps, and SlurmUser=root keeps the set-up
to one user) and the Debian 12 packages ``slurm-wlm munge`` (``scripts/setup.sh`` installs
them). Anything missing or a daemon that does not come up is an error, not a skip: the job
scripts are part of the product and CI must run their tests.

Known facts about SLURM 22.05 as Debian packages it, which shape the configuration:
``srun --mpi=pmix`` works with Debian's OpenMPI (pmi2 does not), there is no accounting daemon
(so no sacct: job states come from ``scontrol show job ID -o``, kept for MinJobAge seconds),
and the cgroup plugins are not needed (proctrack/linuxproc, task/none work in containers).

Teardown cancels the jobs still in the queue, stops the three daemons by the pids in their pid
files (SIGTERM, then SIGKILL after a grace period) and removes the temporary directory, which
it created (HPCGFMD_KEEP_SLURM=1 keeps it, with the logs); nothing else is touched.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from pathlib import Path

DAEMONS = ("munged", "slurmctld", "slurmd")
CLIENTS = ("sbatch", "scontrol", "sinfo", "squeue", "scancel", "srun")
INSTALL_HINT = (
    "install them with `bash scripts/setup.sh` (apt packages slurm-wlm munge;"
    " Debian 12: SLURM 22.05)"
)
# Job states after which a job does not change any more (JobState= of scontrol).
FINAL_STATES = {
    "COMPLETED",
    "FAILED",
    "CANCELLED",
    "TIMEOUT",
    "NODE_FAIL",
    "PREEMPTED",
    "OUT_OF_MEMORY",
    "BOOT_FAIL",
    "DEADLINE",
}


class ClusterError(RuntimeError):
    """The cluster could not be set up or did not behave; the message says why."""


def _free_ports(count):
    """``count`` distinct TCP ports that are free right now (bound once to port 0)."""
    sockets = []
    try:
        for _ in range(count):
            s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            s.bind(("127.0.0.1", 0))
            sockets.append(s)
        return [s.getsockname()[1] for s in sockets]
    finally:
        for s in sockets:
            s.close()


def _tail(path, lines=40):
    try:
        text = Path(path).read_text(errors="replace").splitlines()
    except OSError as err:
        return f"({path}: {err})"
    return "\n".join(text[-lines:])


def client_environment(base=None):
    """``base`` (default os.environ) without any SLURM job/submission variables.

    When the tests themselves run inside a SLURM job, inherited ``SLURM_JOB_ID`` and friends
    would make srun/sbatch talk about that job of another cluster.
    """
    env = dict(os.environ if base is None else base)
    for key in list(env):
        if key.startswith(("SLURM_", "SBATCH_", "SRUN_", "SALLOC_", "SQUEUE_", "SINFO_")):
            del env[key]
    return env


class SlurmCluster:
    """munged + slurmctld + slurmd on this host, all files under :attr:`root`."""

    def __init__(self, root=None, cluster_name="hpcgfmdtest", memory_mb=2048):
        self.root = Path(root or tempfile.mkdtemp(prefix="hpcgfmd-slurm-"))
        self.created_root = root is None
        # munged insists that everyone may traverse the directories above its socket
        os.chmod(self.root, 0o755)
        self.cluster_name = cluster_name
        self.memory_mb = memory_mb
        self.host = socket.gethostname().split(".")[0]
        self.conf = self.root / "slurm.conf"
        self.munge_dir = self.root / "munge"
        self.log_dir = self.root / "log"
        self.pid_files = {
            "munged": self.munge_dir / "munged.pid",
            "slurmctld": self.root / "run" / "slurmctld.pid",
            "slurmd": self.root / "run" / "slurmd.pid",
        }
        self.logs = {
            "munged": self.log_dir / "munged.log",
            "slurmctld": self.log_dir / "slurmctld.log",
            "slurmd": self.log_dir / "slurmd.log",
        }
        self.started = []  # daemons whose pid files this harness owns, in start order
        self.env = dict(client_environment(), SLURM_CONF=str(self.conf))

    # --- set-up -------------------------------------------------------------------------------
    def check_installed(self):
        missing = [
            name for name in DAEMONS + CLIENTS if shutil.which(name, path=_sbin_path()) is None
        ]
        if missing:
            raise ClusterError(
                f"SLURM/munge programs not found: {', '.join(missing)}; " + INSTALL_HINT
            )
        if os.geteuid() != 0:
            raise ClusterError(
                "the private SLURM cluster needs root (slurmd launches the job"
                f" steps, SlurmUser=root); running as uid {os.geteuid()}"
            )

    def _node_line(self):
        """The NodeName line from ``slurmd -C`` (this machine as slurmd sees it), memory capped.

        With CPUs/sockets/cores exactly as detected slurmd registers without complaint; a
        RealMemory above the detected one would drain the node, so use the smaller of both.
        """
        detected = {}
        try:
            out = subprocess.run(
                [_which("slurmd"), "-C"], capture_output=True, text=True, timeout=30, env=self.env
            ).stdout
            first = out.splitlines()[0] if out.strip() else ""
            detected = dict(item.split("=", 1) for item in first.split() if "=" in item)
        except (OSError, subprocess.SubprocessError, ValueError):
            pass
        cpus = detected.get("CPUs") or str(os.cpu_count() or 1)
        line = f"NodeName={self.host} NodeAddr=127.0.0.1 CPUs={cpus}"
        for key in ("Boards", "SocketsPerBoard", "CoresPerSocket", "ThreadsPerCore"):
            if key in detected:
                line += f" {key}={detected[key]}"
        memory = min(self.memory_mb, int(detected.get("RealMemory", self.memory_mb)))
        return line + f" RealMemory={memory} State=UNKNOWN", int(cpus)

    def write_config(self):
        for sub in ("state", "spool", "run", "log"):
            (self.root / sub).mkdir(parents=True, exist_ok=True)
        ctld_port, slurmd_port = _free_ports(2)
        node, self.cpus = self._node_line()
        plugstack = self.root / "plugstack.conf"  # empty: no site SPANK plugins
        plugstack.write_text("")
        r = self.root
        self.conf.write_text(f"""\
# Private single-node test cluster written by tests/slurm_cluster.py
ClusterName={self.cluster_name}
SlurmctldHost={self.host}(127.0.0.1)
SlurmctldPort={ctld_port}
SlurmdPort={slurmd_port}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={self.munge_dir / "munge.socket"}
StateSaveLocation={r / "state"}
SlurmdSpoolDir={r / "spool"}
SlurmctldPidFile={self.pid_files["slurmctld"]}
SlurmdPidFile={self.pid_files["slurmd"]}
SlurmctldLogFile={self.logs["slurmctld"]}
SlurmdLogFile={self.logs["slurmd"]}
SlurmctldDebug=info
SlurmdDebug=info
PlugStackConfig={plugstack}
MailProg=/bin/true
# srun --mpi=pmix is given explicitly by the job scripts, as on most sites
MpiDefault=none
# no cgroups: works in containers and needs no systemd
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
ReturnToService=2
SlurmctldTimeout=30
SlurmdTimeout=30
MessageTimeout=10
InactiveLimit=0
KillWait=5
OverTimeLimit=0
# keep finished jobs visible to scontrol for the whole test session (there is no sacct)
MinJobAge=3600
{node}
PartitionName=test Nodes={self.host} Default=YES MaxTime=INFINITE State=UP OverSubscribe=NO
""")

    def start_munge(self):
        # munged checks that its socket directory is not writable by others; 0755 as in
        # /run/munge. The key: 1 KiB of random bytes, readable by its owner only.
        self.munge_dir.mkdir(mode=0o755, parents=True, exist_ok=True)
        os.chmod(self.munge_dir, 0o755)
        key = self.munge_dir / "munge.key"
        fd = os.open(key, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "wb") as f:
            f.write(os.urandom(1024))
        self._start(
            "munged",
            [
                _which("munged"),
                f"--socket={self.munge_dir / 'munge.socket'}",
                f"--key-file={key}",
                f"--pid-file={self.pid_files['munged']}",
                f"--log-file={self.logs['munged']}",
                f"--seed-file={self.munge_dir / 'munged.seed'}",
            ],
        )

    def _start(self, name, argv):
        """Start a daemon that forks into the background and wait for its pid file."""
        done = subprocess.run(
            argv, capture_output=True, text=True, timeout=60, env=self.env, stdin=subprocess.DEVNULL
        )
        if done.returncode != 0:
            raise ClusterError(
                f"{name} did not start (status {done.returncode}): "
                f"{done.stderr.strip()} {done.stdout.strip()}\n{name} log:\n"
                + _tail(self.logs[name])
            )
        self.started.append(name)  # from here on teardown stops it (once its pid file exists)
        deadline = time.monotonic() + 30
        while self._pid(name) is None:
            if time.monotonic() > deadline:
                raise ClusterError(
                    f"{name} wrote no pid file {self.pid_files[name]}\n"
                    f"{name} log:\n" + _tail(self.logs[name])
                )
            time.sleep(0.1)

    def start(self, timeout=60.0):
        """Write the configuration, start the daemons, wait until the node is idle."""
        self.check_installed()
        self.write_config()
        self.start_munge()
        # -i would ignore saved state; the state directory is new anyway
        self._start("slurmctld", [_which("slurmctld")])
        self._start("slurmd", [_which("slurmd")])
        deadline = time.monotonic() + timeout
        state = ""
        while time.monotonic() < deadline:
            done = subprocess.run(
                ["sinfo", "-h", "-N", "-n", self.host, "-o", "%T"],
                capture_output=True,
                text=True,
                timeout=30,
                env=self.env,
            )
            state = done.stdout.strip() or done.stderr.strip()
            if done.returncode == 0 and state == "idle":
                return self
            for name in self.started:
                if not self._alive(name):
                    raise ClusterError(f"{name} died during start-up\n" + self.diagnostics())
            time.sleep(0.5)
        raise ClusterError(
            f"node {self.host} not idle after {timeout:.0f} s (sinfo: {state!r})\n"
            + self.diagnostics()
        )

    # --- teardown -----------------------------------------------------------------------------
    def _pid(self, name):
        try:
            return int(self.pid_files[name].read_text().split()[0])
        except (OSError, ValueError, IndexError):
            return None

    def _alive(self, name):
        pid = self._pid(name)
        if pid is None:
            return False
        try:  # the pid must still be our daemon, not a recycled number
            cmdline = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")[0]
        except OSError:
            return False
        return os.path.basename(cmdline.decode(errors="replace")) == name

    def _cancel_all(self, timeout=20.0):
        """Cancel every job of this cluster and wait until none runs (steps die with them)."""

        def run(*argv):
            return subprocess.run(argv, capture_output=True, text=True, timeout=30, env=self.env)

        try:
            run("scancel", "--user=root")
            deadline = time.monotonic() + timeout
            while time.monotonic() < deadline:
                if not run("squeue", "-h", "-o", "%i").stdout.strip():
                    return
                time.sleep(0.5)
        except (OSError, subprocess.SubprocessError):
            pass

    def stop(self, grace=10.0):
        """Stop the daemons this harness started, by their pid files, in reverse order."""
        if "slurmctld" in self.started and self._alive("slurmctld"):
            self._cancel_all()
        for name in reversed(self.started):
            pid = self._pid(name)
            if pid is None or not self._alive(name):
                continue
            os.kill(pid, signal.SIGTERM)
            deadline = time.monotonic() + grace
            while self._alive(name) and time.monotonic() < deadline:
                time.sleep(0.1)
            if self._alive(name):
                os.kill(pid, signal.SIGKILL)
        self.started = []

    def remove(self):
        """Delete the directory if this harness created it (HPCGFMD_KEEP_SLURM=1 keeps it)."""
        if os.environ.get("HPCGFMD_KEEP_SLURM"):
            print(f"slurm_cluster: kept {self.root}")
        elif self.created_root:
            shutil.rmtree(self.root, ignore_errors=True)

    # --- use ----------------------------------------------------------------------------------
    def run(self, *argv, check=True, timeout=60, **kwargs):
        """A client command (sbatch, scontrol, ...) against this cluster."""
        kwargs.setdefault("env", self.env)
        done = subprocess.run(
            [str(a) for a in argv], capture_output=True, text=True, timeout=timeout, **kwargs
        )
        if check and done.returncode != 0:
            raise ClusterError(
                f"{' '.join(map(str, argv))}: status {done.returncode}:"
                f" {done.stderr.strip()}\n" + self.diagnostics()
            )
        return done

    def sbatch(self, *argv, env=None, cwd=None):
        """Submit (``sbatch --parsable ARGV``) and return the job id (an int)."""
        done = self.run("sbatch", "--parsable", *argv, env=env or self.env, cwd=cwd)
        return int(done.stdout.strip().split(";")[0])

    def job(self, job_id):
        """The fields of ``scontrol show job ID -o`` as a dict ({} when unknown).

        For an array job the first element's record is returned; use ``jobs`` for all.
        """
        records = self.jobs(job_id)
        return records[0] if records else {}

    def jobs(self, job_id):
        done = self.run("scontrol", "show", "job", str(job_id), "-o", check=False)
        if done.returncode != 0:
            return []
        return [_fields(line) for line in done.stdout.splitlines() if line.strip()]

    def all_jobs(self):
        done = self.run("scontrol", "show", "job", "-o", check=False)
        if done.returncode != 0 or "No jobs" in done.stdout:
            return []
        return [_fields(line) for line in done.stdout.splitlines() if line.startswith("JobId=")]

    def wait(self, job_id, timeout=120.0, states=FINAL_STATES, poll=0.2):
        """Poll until every record of ``job_id`` (all array elements) is in ``states``."""
        deadline = time.monotonic() + timeout
        records = []
        while time.monotonic() < deadline:
            records = self.jobs(job_id)
            if records and all(r.get("JobState") in states for r in records):
                return records
            time.sleep(poll)
        raise ClusterError(
            f"job {job_id} not in {sorted(states)} after {timeout:.0f} s: "
            + "; ".join(
                f"{r.get('JobId')}={r.get('JobState')} ({r.get('Reason')})" for r in records
            )
            + "\n"
            + self.diagnostics(job_id)
        )

    def diagnostics(self, *job_ids, lines=40):
        """Job records, their output files and the daemon log tails, for assertion messages."""
        parts = []
        for job_id in job_ids:
            for record in self.jobs(job_id):
                parts.append(
                    "scontrol: "
                    + " ".join(
                        f"{k}={record.get(k)}"
                        for k in (
                            "JobId",
                            "ArrayTaskId",
                            "JobState",
                            "Reason",
                            "ExitCode",
                            "RunTime",
                            "Command",
                            "WorkDir",
                            "StdOut",
                        )
                    )
                )
                for key in ("StdOut", "StdErr"):
                    path = record.get(key)
                    if (
                        path
                        and os.path.isfile(path)
                        and (key == "StdOut" or path != record.get("StdOut"))
                    ):
                        parts.append(f"--- {path} ---\n{_tail(path, lines * 2)}")
        for name in ("slurmctld", "slurmd"):
            parts.append(f"--- {self.logs[name]} (tail) ---\n{_tail(self.logs[name], lines)}")
        return "\n".join(parts)


def _fields(line):
    """``Key=Value Key=Value ...`` of ``scontrol -o`` (values do not contain spaces here)."""
    out = {}
    for item in line.split():
        if "=" in item:
            key, value = item.split("=", 1)
            out.setdefault(key, value)
    return out


def _sbin_path():
    # daemons live in /usr/sbin, which a non-login root shell's PATH may lack
    return os.pathsep.join([os.environ.get("PATH", ""), "/usr/sbin", "/usr/local/sbin", "/sbin"])


def _which(name):
    path = shutil.which(name, path=_sbin_path())
    if path is None:
        raise ClusterError(f"{name} not found; " + INSTALL_HINT)
    return path


def cluster():
    """Generator for a module-scoped pytest fixture: a running cluster, stopped afterwards.

    ``SLURM_CONF`` is exported into ``os.environ`` while the cluster runs (restored after).
    Set-up errors raise :class:`ClusterError`, which pytest reports as an error of every test
    that uses the fixture (never a skip).
    """
    c = SlurmCluster()
    previous = os.environ.get("SLURM_CONF")
    try:
        c.start()
        os.environ["SLURM_CONF"] = str(c.conf)
        yield c
    finally:
        if previous is None:
            os.environ.pop("SLURM_CONF", None)
        else:
            os.environ["SLURM_CONF"] = previous
        c.stop()
        c.remove()
