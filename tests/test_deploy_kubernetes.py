"""The Kubernetes fleet manifests (deploy/kubernetes) and the container recipe around them: rendered
for 3 arms as kustomize would, validated offline against the schemas of a current Kubernetes
release, and checked for names, the standard ports (manual 2.1 command port 502, 2.2 report ports
30001-30003), probes through the client's readiness probe, a volume per arm and no admin channel."""

from __future__ import annotations

import copy
import json
import re
import shlex
import subprocess
from pathlib import Path
from typing import Any

import pytest

yaml = pytest.importorskip("yaml")
kubernetes_validate = pytest.importorskip("kubernetes_validate")

ROOT = Path(__file__).resolve().parent.parent
KDIR = ROOT / "deploy" / "kubernetes"
K8S_VERSION = "1.33.0"


def render(arms: int) -> list[dict[str, Any]]:
    """The kustomization's resources with its labels and its replica count set to ``arms``."""
    kust = yaml.safe_load((KDIR / "kustomization.yaml").read_text())
    docs: list[dict[str, Any]] = []
    for name in kust["resources"]:
        docs.extend(d for d in yaml.safe_load_all((KDIR / name).read_text()) if d)
    labels = {k: v for entry in kust.get("labels", []) for k, v in entry["pairs"].items()}
    images = {i["name"]: f"{i.get('newName', i['name'])}:{i.get('newTag', 'latest')}" for i in kust["images"]}
    counts = {r["name"]: arms for r in kust.get("replicas", [])}
    for doc in docs:
        doc["metadata"].setdefault("labels", {}).update(labels)
        if doc["kind"] == "StatefulSet":
            doc["spec"]["replicas"] = counts.get(doc["metadata"]["name"], doc["spec"]["replicas"])
            for c in doc["spec"]["template"]["spec"]["containers"]:
                c["image"] = images.get(c["image"], c["image"])
            doc["spec"]["selector"]["matchLabels"].update(labels)
            doc["spec"]["template"]["metadata"]["labels"].update(labels)
        if doc["kind"] == "Service":
            doc["spec"]["selector"].update(labels)
    return docs


def by_kind(docs: list[dict[str, Any]], kind: str) -> dict[str, Any]:
    (doc,) = [d for d in docs if d["kind"] == kind]
    return doc


def dockerfile_entrypoint() -> list[str]:
    line = next(x for x in (ROOT / "Dockerfile").read_text().splitlines() if x.startswith("ENTRYPOINT"))
    return list(json.loads(line.removeprefix("ENTRYPOINT")))


def test_manifests_validate_offline_against_the_kubernetes_schemas() -> None:
    for doc in render(3):
        kubernetes_validate.validate(copy.deepcopy(doc), K8S_VERSION, strict=True)


def test_validation_refuses_a_broken_statefulset() -> None:
    sts = copy.deepcopy(by_kind(render(3), "StatefulSet"))
    sts["spec"]["replicas"] = "three"
    with pytest.raises(kubernetes_validate.ValidationError):
        kubernetes_validate.validate(sts, K8S_VERSION, strict=True)


def test_three_arms_have_stable_names_on_a_headless_service_with_the_standard_ports() -> None:
    docs = render(3)
    sts, svc = by_kind(docs, "StatefulSet"), by_kind(docs, "Service")
    assert sts["spec"]["replicas"] == 3
    assert svc["spec"]["clusterIP"] == "None"
    assert sts["spec"]["serviceName"] == svc["metadata"]["name"] == "xarm-emu"
    assert [f"{sts['metadata']['name']}-{i}.{svc['metadata']['name']}" for i in range(3)] == \
        ["arm-0.xarm-emu", "arm-1.xarm-emu", "arm-2.xarm-emu"]
    pod_labels = sts["spec"]["template"]["metadata"]["labels"]
    assert svc["spec"]["selector"].items() <= pod_labels.items()
    (container,) = sts["spec"]["template"]["spec"]["containers"]
    ports = {p["name"]: p["containerPort"] for p in container["ports"]}
    assert ports == {"command": 502, "report-normal": 30001, "report-rich": 30002, "report-develop": 30003}
    assert {p["port"] for p in svc["spec"]["ports"]} == set(ports.values())
    assert {p["targetPort"] for p in svc["spec"]["ports"]} == set(ports)


def test_probes_go_through_the_readiness_probe_on_the_pod() -> None:
    (container,) = by_kind(render(3), "StatefulSet")["spec"]["template"]["spec"]["containers"]
    venv_python = str(Path(dockerfile_entrypoint()[0]).with_name("python"))
    for probe in ("readinessProbe", "livenessProbe"):
        cmd = container[probe]["exec"]["command"]
        assert cmd[:3] == [venv_python, "-m", "xarm_emu.client.ready"]
        assert cmd[cmd.index("--host") + 1] == "127.0.0.1"
        assert float(cmd[cmd.index("--wait") + 1]) < container[probe]["timeoutSeconds"]


def test_a_volume_claim_per_arm_holds_the_saved_configuration() -> None:
    sts = by_kind(render(3), "StatefulSet")
    (claim,) = sts["spec"]["volumeClaimTemplates"]
    (container,) = sts["spec"]["template"]["spec"]["containers"]
    mounts = {m["name"]: m["mountPath"] for m in container["volumeMounts"]}
    env = {e["name"]: e["value"] for e in container["env"]}
    assert mounts[claim["metadata"]["name"]] == env["XARM_EMU_SERVE_CONFIG_DIR"] == "/var/lib/xarm-emu"
    assert claim["spec"]["accessModes"] == ["ReadWriteOnce"]
    assert "VOLUME [\"/var/lib/xarm-emu\"]" in (ROOT / "Dockerfile").read_text()


def test_the_pod_runs_the_image_entrypoint_with_options_from_the_configmap() -> None:
    docs = render(3)
    sts, cm = by_kind(docs, "StatefulSet"), by_kind(docs, "ConfigMap")
    (container,) = sts["spec"]["template"]["spec"]["containers"]
    assert container["command"][:2] == ["/bin/sh", "-c"]
    script = container["command"][2]
    last = shlex.split(script.split(";")[-1])
    assert last[0] == "exec" and last[1:3] == dockerfile_entrypoint() and last[3:] == ["$@"]
    # The image test starts containers with the image's entrypoint and XARM_EMU_SERVE_* variables alone.
    checks = (ROOT / "scripts" / "image_checks.py").read_text()
    assert "--entrypoint" not in checks and "XARM_EMU_SERVE_HOST=" in checks
    (arms,) = [v for v in sts["spec"]["template"]["spec"]["volumes"] if "configMap" in v]
    assert arms["configMap"]["name"] == cm["metadata"]["name"]
    assert "all.env" in cm["data"]
    for key, text in cm["data"].items():
        assert re.fullmatch(r"all\.env|arm-\d+\.env", key)
        for line in text.strip().splitlines():
            name = line.split("=", 1)[0]
            assert name.startswith("XARM_EMU_SERVE_") and name != "XARM_EMU_SERVE_ADMIN", line


def test_the_configmap_sets_serve_options_the_cli_accepts(tmp_path: Path) -> None:
    """Each per-arm file, read by the pod's shell, gives ``serve`` options it accepts (checked with
    an option refused on purpose so nothing binds: a bad --loop exits 2 after parsing)."""
    from typer.testing import CliRunner

    from xarm_emu.cli import app

    cm = by_kind(render(3), "ConfigMap")
    for key in ("all.env", "arm-2.env"):
        env = dict(line.split("=", 1) for line in cm["data"][key].strip().splitlines())
        env["XARM_EMU_SERVE_MODEL"] = "9"  # out of 5..7: click refuses it, so the variable is read
        res = CliRunner().invoke(app, ["serve"], env=env, auto_envvar_prefix="XARM_EMU")
        assert res.exit_code == 2 and "--model" in res.output, res.output


def test_nothing_exposes_the_admin_channel() -> None:
    sts = by_kind(render(3), "StatefulSet")
    (container,) = sts["spec"]["template"]["spec"]["containers"]
    text = (json.dumps(render(3)) + (ROOT / "Dockerfile").read_text()
            + (ROOT / "deploy" / "compose.yaml").read_text())
    assert "--admin" not in text
    assert "XARM_EMU_SERVE_ADMIN" not in text.replace("Keep XARM_EMU_SERVE_ADMIN", "")
    assert 10502 not in [p["containerPort"] for p in container["ports"]]
    sec = container["securityContext"]
    assert sec["allowPrivilegeEscalation"] is False and sec["capabilities"]["drop"] == ["ALL"]


def test_compose_file_gives_each_arm_its_own_loopback_address_and_volume() -> None:
    spec = yaml.safe_load((ROOT / "deploy" / "compose.yaml").read_text())
    hosts = [s["environment"]["XARM_EMU_SERVE_HOST"] for s in spec["services"].values()]
    assert len(set(hosts)) == len(hosts) >= 2
    assert all(h.startswith("127.") and h != "127.0.0.1" for h in hosts)
    vols = [s["volumes"][0].split(":")[0] for s in spec["services"].values()]
    assert len(set(vols)) == len(vols) and set(vols) <= set(spec["volumes"])


def test_the_image_is_set_in_kustomize_to_a_registry_name() -> None:
    (container,) = by_kind(render(3), "StatefulSet")["spec"]["template"]["spec"]["containers"]
    name, tag = container["image"].rsplit(":", 1)
    assert "/" in name and "." in name.split("/", 1)[0] and tag  # a registry host, a path, a tag
    kust = yaml.safe_load((KDIR / "kustomization.yaml").read_text())
    assert [i["name"] for i in kust["images"]] == ["xarm-emu"] and "newName" in kust["images"][0]


def test_the_memory_request_covers_an_arm_and_its_probe() -> None:
    doc = (ROOT / "docs" / "container.md").read_text()
    at_rest = int(re.search(r"\| (\d+) MiB \|", doc).group(1))  # type: ignore[union-attr]
    probe = int(re.search(r"while it runs \| \| about (\d+) MiB", doc).group(1))  # type: ignore[union-attr]
    (container,) = by_kind(render(3), "StatefulSet")["spec"]["template"]["spec"]["containers"]
    request = int(container["resources"]["requests"]["memory"].removesuffix("Mi"))
    limit = int(container["resources"]["limits"]["memory"].removesuffix("Mi"))
    assert at_rest + probe <= request <= limit
    assert f"{request} MiB per arm" in " ".join(doc.split())


def _health_args(tmp_path: Path, env: dict[str, str], cmdline: list[str] | None = None) -> list[str]:
    """What the image's health script runs, with a stand-in xarm-emu and process 1's command line."""
    fake = tmp_path / "python"
    fake.write_text('#!/bin/sh\necho "$@" > "$0.args"\n')
    fake.chmod(0o755)
    proc1 = tmp_path / "cmdline"
    argv = cmdline or ["/opt/xarm-emu/bin/xarm-emu", "serve"]
    proc1.write_bytes(b"".join(a.encode() + b"\0" for a in argv))
    env = {"PATH": f"{tmp_path}:/usr/bin:/bin", "XARM_EMU_HEALTH_CMDLINE": str(proc1), **env}
    subprocess.run([str(ROOT / "scripts" / "container-health")], env=env, check=True)
    return (tmp_path / "python.args").read_text().split()


def test_the_health_script_probes_what_serve_was_given_by_argument(tmp_path: Path) -> None:
    args = _health_args(tmp_path, {"XARM_EMU_SERVE_HOST": "127.0.0.9"},
                        ["/opt/xarm-emu/bin/xarm-emu", "serve", "--host", "127.0.0.5", "--port=5020",
                         "--develop-port", "31003", "--config-dir", "a b"])
    assert args[args.index("--host") + 1] == "127.0.0.5"  # the argument wins, as in serve itself
    assert args[args.index("--port") + 1] == "5020"


def test_the_health_script_probes_loopback_for_a_wildcard_address(tmp_path: Path) -> None:
    env = {"XARM_EMU_SERVE_HOST": "0.0.0.0", "XARM_EMU_SERVE_PORT": "5020"}
    args = _health_args(tmp_path, env)
    assert args[:3] == ["-m", "xarm_emu.client.ready", "--wait"]
    assert args[args.index("--host") + 1] == "127.0.0.1" and args[args.index("--port") + 1] == "5020"
