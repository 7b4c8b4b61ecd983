#!/usr/bin/env bash
# deploy/install-lab.sh — installs a palp lab machine from a built tree: the binaries, the udev
# rules for the USB devices, the palpd systemd unit, its config, real-time limits for the palp
# group, the lab launcher and the docs; creates the "palp" system user and group.
#
# Data flow: BUILD_DIR/server/{palp,palpd} and BUILD_DIR/client/{palpview,palpchart} (those two
# when built) -> PREFIX/bin; deploy/lab.sh -> PREFIX/bin/palp-lab; deploy/lab.example.toml,
# deploy/palpd.toml -> PREFIX/share/palp/; docs -> PREFIX/share/doc/palp/;
# deploy/udev/70-palp.rules -> /etc/udev/rules.d/; deploy/systemd/palpd.service (with
# /usr/local replaced by PREFIX) -> /etc/systemd/system/; deploy/palpd.toml (with a random
# controller token) -> /etc/palp/palpd.toml only when that file does not exist yet (an existing
# config is never overwritten); the rtprio/memlock limits of group palp ->
# /etc/security/limits.d/palp.conf. Then udev and systemd reload their files.
# Idempotent: a file whose content and mode are already in place is reported "unchanged" and
# not touched; the user and group are created only when missing. --dry-run prints what it
# would do and changes nothing; --destdir stages everything under a directory (no user, no
# reloads: for packaging and tests).
set -euo pipefail

program=$(basename "$0")
repo=$(cd "$(dirname "$0")/.." && pwd)

usage() {
  cat <<EOF
usage: $program [options]

Installs palp on a lab machine (run as root, e.g. with sudo): binaries, udev rules, the palpd
systemd unit, /etc/palp/palpd.toml, the palp user and group. Safe to run again after a rebuild.

Options:
  --prefix DIR       where binaries, the launcher and docs go (default /usr/local)
  --build-dir DIR    the CMake build directory to install from (default $repo/build)
  --destdir DIR      stage every file under DIR instead of / (no user, no reloads; no root needed)
  --operator USER    add USER to group palp (device access, real-time limits); repeatable
  --enable           enable and start palpd.service (systemctl enable --now)
  --dry-run          print what would be installed and run, change nothing
  -h, --help         show this help
EOF
}

die() {
  echo "$program: error: $*" >&2
  exit 1
}
die_usage() {
  echo "$program: error: $*" >&2
  exit 2
}

prefix=/usr/local
build_dir=$repo/build
destdir=""
dry_run=0
enable=0
operators=()
while (($# > 0)); do
  case $1 in
    --prefix | --build-dir | --destdir | --operator)
      (($# >= 2)) || die_usage "$1 needs a value"
      case $1 in
        --prefix) prefix=$2 ;;
        --build-dir) build_dir=$2 ;;
        --destdir) destdir=$2 ;;
        --operator) operators+=("$2") ;;
      esac
      shift
      ;;
    --enable) enable=1 ;;
    --dry-run) dry_run=1 ;;
    -h | --help)
      usage
      exit 0
      ;;
    *) die_usage "unknown argument '$1' (see --help)" ;;
  esac
  shift
done
[[ $prefix == /* ]] || die_usage "--prefix must be an absolute path, got '$prefix'"
prefix=${prefix%/}
[[ -n $prefix ]] || prefix=/
[[ -z $destdir ]] || destdir=$(realpath -m "$destdir")
if ((!dry_run)) && [[ -z $destdir ]] && ((EUID != 0)); then
  die "needs root to install into /etc and to create the palp user (sudo $0 ...); --dry-run shows what it would do"
fi
if [[ -n $destdir ]] && { ((enable)) || ((${#operators[@]} > 0)); }; then
  die_usage "--enable and --operator change the running system; they do not go with --destdir"
fi

changed=0
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

run() { # prints the command; runs it unless --dry-run
  printf 'run:'
  printf ' %q' "$@"
  printf '\n'
  ((dry_run)) || "$@"
}

# install_file SRC DEST MODE [GROUP]: DEST is relative to / (staged under --destdir).
install_file() {
  local source=$1 target=$destdir$2 mode=$3 group=${4:-}
  if [[ -f $target ]] && cmp -s "$source" "$target" &&
    [[ $(stat -c %a "$target") == "${mode#0}" ]] &&
    { [[ -z $group || -n $destdir ]] || [[ $(stat -c %G "$target") == "$group" ]]; }; then
    echo "unchanged: $target"
    return 0
  fi
  echo "install: $source -> $target (mode $mode${group:+, group $group})"
  changed=1
  ((dry_run)) && return 0
  mkdir -p "$(dirname "$target")"
  if [[ -n $group && -z $destdir ]]; then
    install -m "$mode" -o root -g "$group" "$source" "$target"
  else
    install -m "$mode" "$source" "$target"
  fi
}

# ------------------------------------------------------------------------------ user and group
if [[ -n $destdir ]]; then
  echo "skipped (--destdir): the palp system user and group"
else
  if getent group palp >/dev/null; then
    echo "unchanged: group palp"
  else
    run groupadd --system palp
  fi
  if getent passwd palp >/dev/null; then
    echo "unchanged: user palp"
  else
    run useradd --system --gid palp --home-dir /var/lib/palp --no-create-home \
      --shell /usr/sbin/nologin --comment "palp real-time server" palp
  fi
  for operator in "${operators[@]}"; do
    if id -nG "$operator" 2>/dev/null | tr ' ' '\n' | grep -qx palp; then
      echo "unchanged: $operator in group palp"
    else
      run usermod --append --groups palp "$operator"
      echo "note: $operator gets the group at the next login"
    fi
  done
fi

# ------------------------------------------------------------------------------ binaries
for name in palp palpd; do
  binary=$build_dir/server/$name
  if [[ -x $binary ]]; then
    install_file "$binary" "$prefix/bin/$name" 0755
  elif ((dry_run)); then
    echo "missing: $binary (build it first: deploy/build.sh); would install -> $destdir$prefix/bin/$name"
  else
    die "$binary not found: build first (deploy/build.sh, or --build-dir DIR)"
  fi
done
for name in palpview palpchart; do
  binary=$build_dir/client/$name
  if [[ -x $binary ]]; then
    install_file "$binary" "$prefix/bin/$name" 0755
  else
    echo "skipped: $binary not built (needs VTK; display machines need palpview)"
  fi
done
install_file "$repo/deploy/lab.sh" "$prefix/bin/palp-lab" 0755

# ------------------------------------------------------------------------------ shared files
install_file "$repo/deploy/lab.example.toml" "$prefix/share/palp/lab.example.toml" 0644
install_file "$repo/deploy/palpd.toml" "$prefix/share/palp/palpd.toml.example" 0644
for doc in operations.md palpd.md usb-protocol.md palpview.md; do
  [[ ! -f $repo/docs/$doc ]] || install_file "$repo/docs/$doc" "$prefix/share/doc/palp/$doc" 0644
done

# ------------------------------------------------------------------------------ system files
install_file "$repo/deploy/udev/70-palp.rules" /etc/udev/rules.d/70-palp.rules 0644

sed "s#/usr/local#$prefix#g" "$repo/deploy/systemd/palpd.service" >"$work/palpd.service"
install_file "$work/palpd.service" /etc/systemd/system/palpd.service 0644

cat >"$work/limits.conf" <<'EOF'
# /etc/security/limits.d/palp.conf (deploy/install-lab.sh): members of group palp may run
# palpd by hand with a SCHED_FIFO loop and locked memory (the service gets the same limits
# from palpd.service). Takes effect at the next login.
@palp - rtprio 90
@palp - memlock unlimited
EOF
install_file "$work/limits.conf" /etc/security/limits.d/palp.conf 0644

config=/etc/palp/palpd.toml
if [[ -f $destdir$config ]]; then
  echo "kept: $destdir$config (existing config never overwritten; the shipped example is $prefix/share/palp/palpd.toml.example)"
else
  token=$(od -An -N16 -tx1 /dev/urandom | tr -d ' \n')
  sed "s|^# token = \"CHANGE-ME\"|token = \"$token\"|" "$repo/deploy/palpd.toml" >"$work/palpd.toml"
  grep -q "^token = \"$token\"" "$work/palpd.toml" || die "could not set the token in the config"
  install_file "$work/palpd.toml" "$config" 0640 palp
  echo "note: a random controller token was written to $config (palpview --controller --token ...)"
fi

# ------------------------------------------------------------------------------ reloads
if [[ -n $destdir ]]; then
  echo "skipped (--destdir): udevadm reload/trigger, systemctl daemon-reload"
else
  if command -v udevadm >/dev/null || ((dry_run)); then
    run udevadm control --reload
    run udevadm trigger --subsystem-match=usb --action=change
  else
    echo "warning: udevadm not found: replug the USB devices after installing udev"
  fi
  if command -v systemctl >/dev/null || ((dry_run)); then
    run systemctl daemon-reload
    if ((enable)); then
      run systemctl enable --now palpd.service
    elif ((changed)) && systemctl is-active --quiet palpd.service 2>/dev/null; then
      echo "note: palpd.service is running the previous files: systemctl restart palpd"
    fi
  fi
fi
if ((dry_run)); then
  echo "dry run: nothing was changed"
elif ((changed)); then
  echo "installed; next: docs/operations.md (first start)"
else
  echo "everything was already installed"
fi
