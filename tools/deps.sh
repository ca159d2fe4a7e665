# Sourced by tools/test.sh and tools/demo.sh: makes sure the Debian 12 packages unilod needs are
# installed. Installs what is missing when it can (root, or password-less sudo); otherwise prints
# the exact apt-get line and stops.
UNILOD_DEBIAN_PACKAGES=(
    build-essential cmake ninja-build pkg-config
    libgdal-dev gdal-bin zlib1g-dev libzstd-dev libmeshoptimizer-dev
    nlohmann-json3-dev libcli11-dev
    libgtest-dev
    libvulkan-dev mesa-vulkan-drivers vulkan-validationlayers glslang-tools libglm-dev libpng-dev
    libglfw3-dev libtinygltf-dev xvfb xauth libcairo2-dev fonts-dejavu-core
)

unilod_ensure_packages() {
    local missing=() p
    for p in "${UNILOD_DEBIAN_PACKAGES[@]}"; do
        if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
            missing+=("$p")
        fi
    done
    [ ${#missing[@]} -eq 0 ] && return 0
    echo "unilod: installing missing Debian packages: ${missing[*]}"
    local sudo=()
    if [ "$(id -u)" -ne 0 ]; then
        if command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
            sudo=(sudo)
        else
            echo "unilod: cannot install packages (not root, no password-less sudo). Run:" >&2
            echo "  sudo apt-get install -y ${missing[*]}" >&2
            return 1
        fi
    fi
    "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -q &&
        "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}"
}

# The real-client test of the 3D Tiles export (tests/cesium/run.mjs, issue 20): Debian's Chromium,
# Node.js with npm, and the pinned npm packages (CesiumJS, playwright-core; package-lock.json)
# under tests/cesium/node_modules. Sourced by tools/test.sh only: the demo does not need them.
unilod_ensure_test_client() {
    local missing=()
    command -v chromium >/dev/null 2>&1 || missing+=(chromium)
    command -v node >/dev/null 2>&1 || missing+=(nodejs)
    command -v npm >/dev/null 2>&1 || missing+=(npm)
    if [ ${#missing[@]} -gt 0 ]; then
        local saved=("${UNILOD_DEBIAN_PACKAGES[@]}")
        UNILOD_DEBIAN_PACKAGES=("${missing[@]}")
        unilod_ensure_packages
        local rc=$?
        UNILOD_DEBIAN_PACKAGES=("${saved[@]}")
        [ $rc -eq 0 ] || return $rc
    fi
    local dir
    dir="$(dirname "${BASH_SOURCE[0]}")/../tests/cesium"
    if [ ! -f "$dir/node_modules/.package-lock.json" ] ||
        [ "$dir/package-lock.json" -nt "$dir/node_modules/.package-lock.json" ]; then
        echo "unilod: installing the CesiumJS test client (npm ci in tests/cesium)"
        (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error)
    fi
}
