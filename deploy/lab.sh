#!/usr/bin/env bash
# deploy/lab.sh — the lab launcher: one palpd server and several palpview observer displays, on
# this machine or on others through ssh, started and stopped together.
#
# Data flow: LABFILE (deploy/lab.example.toml: [lab], [server], [[observer]]) is read by a small
# awk reader of the TOML subset it uses -> the palpd command is started (here, or `ssh HOST`),
# its output in LOGDIR/palpd.log -> `palp probe ADDRESS:PORT` is run from here until palpd
# answers (the scene may be prepped first) -> one palpview per observer (DISPLAY, camera,
# preset, name), output in LOGDIR/observer-NAME.log -> the launcher watches them; Ctrl-C,
# SIGTERM, --duration or palpd exiting stops the observers, then palpd (SIGTERM: palpd zeroes
# the force and prints its summary; SIGKILL after 15 s). Remote commands print their pid
# first (PALP_PID=...) so they are stopped by pid with `ssh HOST kill -TERM PID`.
# --dry-run prints every command it would run and runs none of them.
set -euo pipefail

program=$(basename "$0")

usage() {
  cat <<EOF
usage: $program [options] LABFILE

Starts palpd and the observer displays listed in LABFILE (see deploy/lab.example.toml), waits
for palpd with \`palp probe\`, then starts the observers; Ctrl-C stops everything.

Options:
  --dry-run          print every command (one per line, starting with "+ ") and run nothing
  --log-dir DIR      where the logs go (default: lab_dir or a new directory under \$TMPDIR)
  --duration S       stop everything after S seconds (default: until Ctrl-C or palpd exits)
  --wait S           how long to wait for palpd to answer (default: wait_s, else 180)
  -h, --help         show this help

Exit status: 0 after --duration or when palpd stops by itself with status 0, 130 after Ctrl-C,
1 when palpd does not come up or fails, 2 for a usage or lab file error.
EOF
}

die_usage() {
  echo "$program: error: $*" >&2
  exit 2
}

dry_run=0
log_dir=""
duration=0
wait_override=""
lab_file=""
while (($# > 0)); do
  case $1 in
    --dry-run) dry_run=1 ;;
    --log-dir)
      (($# >= 2)) || die_usage "--log-dir needs a directory"
      log_dir=$2
      shift
      ;;
    --duration)
      (($# >= 2)) || die_usage "--duration needs seconds"
      duration=$2
      shift
      ;;
    --wait)
      (($# >= 2)) || die_usage "--wait needs seconds"
      wait_override=$2
      shift
      ;;
    -h | --help)
      usage
      exit 0
      ;;
    -*) die_usage "unknown option '$1' (see --help)" ;;
    *)
      [[ -z $lab_file ]] || die_usage "one LABFILE only, got '$lab_file' and '$1'"
      lab_file=$1
      ;;
  esac
  shift
done
[[ -n $lab_file ]] || die_usage "needs a LABFILE (see deploy/lab.example.toml)"
[[ -r $lab_file ]] || die_usage "cannot read '$lab_file'"
[[ $duration =~ ^[0-9]+$ ]] || die_usage "--duration must be whole seconds, got '$duration'"
[[ -z $wait_override || $wait_override =~ ^[0-9]+$ ]] ||
  die_usage "--wait must be whole seconds, got '$wait_override'"

# ------------------------------------------------------------------------------ lab file
# The TOML subset as lines "SECTION<TAB>INDEX<TAB>KEY<TAB>KIND<TAB>VALUE": KIND s (string),
# n (number), b (boolean), a (one array element), e (an empty array).
read_lab_file() {
  awk '
    function fail(message) {
      printf "%s:%d: %s\n", FILENAME, FNR, message > "/dev/stderr"
      failed = 1
      exit 2
    }
    function skip_space() { sub(/^[ \t]+/, "", rest) }
    # Reads one value at the start of `rest` into value/kind and removes it from `rest`.
    function read_value(    c, i, n, out) {
      c = substr(rest, 1, 1)
      if (c == "\"") {
        out = ""
        n = length(rest)
        for (i = 2; i <= n; i++) {
          c = substr(rest, i, 1)
          if (c == "\\") {
            i++
            c = substr(rest, i, 1)
            if (c != "\\" && c != "\"") fail("only \\\\ and \\\" escapes are supported")
          } else if (c == "\"") {
            rest = substr(rest, i + 1)
            value = out
            kind = "s"
            return
          }
          out = out c
        }
        fail("unterminated string")
      }
      if (c == "\047") {
        i = index(substr(rest, 2), "\047")
        if (i == 0) fail("unterminated string")
        value = substr(rest, 2, i - 1)
        rest = substr(rest, i + 2)
        kind = "s"
        return
      }
      if (match(rest, /^[+-]?[0-9]+(\.[0-9]+)?/)) {
        value = substr(rest, 1, RLENGTH)
        rest = substr(rest, RLENGTH + 1)
        kind = "n"
        return
      }
      if (match(rest, /^(true|false)/)) {
        value = substr(rest, 1, RLENGTH)
        rest = substr(rest, RLENGTH + 1)
        kind = "b"
        return
      }
      fail("expected a string, a number, true or false")
    }
    function emit(k, v) {
      if (v ~ /\t/) fail("tabs are not allowed in values")
      printf "%s\t%s\t%s\t%s\t%s\n", section, number, key, k, v
    }
    BEGIN { section = ""; number = 0 }
    {
      line = $0
      sub(/\r$/, "", line)
      if (line ~ /^[ \t]*(#.*)?$/) next
      if (match(line, /^[ \t]*\[\[[ \t]*observer[ \t]*\]\][ \t]*(#.*)?$/)) {
        section = "observer"
        number++
        next
      }
      if (match(line, /^[ \t]*\[[ \t]*(lab|server)[ \t]*\][ \t]*(#.*)?$/)) {
        section = line
        gsub(/[][ \t]/, "", section)
        sub(/#.*/, "", section)
        if (seen_table[section]++) fail("[" section "] appears twice")
        next
      }
      if (line ~ /^[ \t]*\[/) fail("unknown table " line " (only [lab], [server], [[observer]])")
      if (!match(line, /^[ \t]*[A-Za-z0-9_-]+[ \t]*=[ \t]*/))
        fail("expected key = value")
      if (section == "") fail("key outside a table ([lab], [server] or [[observer]])")
      key = line
      sub(/^[ \t]*/, "", key)
      sub(/[ \t]*=.*/, "", key)
      rest = substr(line, RLENGTH + 1)
      if (seen_key[section, number, key]++) fail("duplicate key " key)
      if (substr(rest, 1, 1) == "[") {
        rest = substr(rest, 2)
        skip_space()
        count = 0
        while (substr(rest, 1, 1) != "]") {
          if (rest == "") fail("arrays must be on one line")
          read_value()
          if (kind != "s" && kind != "n") fail("array elements must be strings or numbers")
          emit("a", value)
          count++
          skip_space()
          if (substr(rest, 1, 1) == ",") {
            rest = substr(rest, 2)
            skip_space()
          } else if (substr(rest, 1, 1) != "]") {
            fail("expected , or ] in an array")
          }
        }
        rest = substr(rest, 2)
        if (count == 0) emit("e", "")
      } else {
        read_value()
        emit(kind, value)
      }
      skip_space()
      if (rest != "" && rest !~ /^#/) fail("unexpected text after the value: " rest)
    }
    END { if (failed) exit 2 }
  ' "$1"
}

declare -A lab=() server=() observer=() lab_arrays=()
observer_count=0
unit=$'\x1f' # separates the elements of an array value

known_key() { # SECTION KEY
  case $1 in
    lab) [[ $2 =~ ^(bin_dir|ssh|wait_s|log_dir|palp)$ ]] ;;
    server) [[ $2 =~ ^(host|address|port|start|config|options|token|palpd)$ ]] ;;
    observer)
      [[ $2 =~ ^(name|host|display|camera|preset|width|height|role|token|env|options|palpview)$ ]]
      ;;
  esac
}

parsed=$(read_lab_file "$lab_file") || exit 2
while IFS=$'\t' read -r section number key kind value; do
  [[ -n $section ]] || continue
  known_key "$section" "$key" || die_usage "$lab_file: unknown key '$key' in [$section]"
  slot="$section.$number.$key"
  case $kind in
    a) lab_arrays[$slot]+="${value}${unit}" ;;
    e) lab_arrays[$slot]="" ;;
    *)
      case $section in
        lab) lab[$key]=$value ;;
        server) server[$key]=$value ;;
        observer) observer[$number.$key]=$value ;;
      esac
      ;;
  esac
  if ((number > observer_count)); then observer_count=$number; fi
done <<<"$parsed"

# An array value of the lab file as the named bash array (empty when absent unless a default).
array_value() { # RESULT-NAME SLOT [DEFAULT...]
  local -n result=$1
  local slot=$2
  shift 2
  if [[ -v lab_arrays[$slot] ]]; then
    local joined=${lab_arrays[$slot]}
    result=()
    while [[ -n $joined ]]; do
      result+=("${joined%%"$unit"*}")
      joined=${joined#*"$unit"}
    done
  else
    result=("$@")
  fi
}

is_local() { [[ -z $1 || $1 == localhost || $1 == 127.0.0.1 || $1 == ::1 ]]; }

program_path() { # NAME [EXPLICIT-PATH]
  if [[ -n ${2:-} ]]; then
    echo "$2"
  elif [[ -n ${lab[bin_dir]:-} ]]; then
    echo "${lab[bin_dir]%/}/$1"
  else
    echo "$1"
  fi
}

# One shell word, quoted only when it needs it (for printing and for ssh's remote shell).
quote_word() {
  if [[ $1 =~ ^[A-Za-z0-9_./:,=+@%-]+$ ]]; then
    printf '%s' "$1"
  else
    printf "'%s'" "${1//\'/\'\\\'\'}"
  fi
}
quote_words() {
  local word first=1
  for word in "$@"; do
    ((first)) || printf ' '
    first=0
    quote_word "$word"
  done
}

array_value ssh_command lab.0.ssh ssh -o BatchMode=yes -o ConnectTimeout=10
wait_s=${wait_override:-${lab[wait_s]:-180}}
[[ $wait_s =~ ^[0-9]+$ ]] || die_usage "$lab_file: wait_s must be whole seconds"

server_host=${server[host]:-localhost}
server_port=${server[port]:-7400}
[[ $server_port =~ ^[0-9]+$ ]] || die_usage "$lab_file: [server] port must be a number"
server_address=${server[address]:-$server_host}
server_start=${server[start]:-true}
[[ $server_start == true || $server_start == false ]] ||
  die_usage "$lab_file: [server] start must be true or false"
# The address seen from HOST: loopback on the server's own host.
address_from() { # HOST
  if [[ $1 == "$server_host" ]] || { is_local "$1" && is_local "$server_host"; }; then
    echo "127.0.0.1:$server_port"
  else
    echo "$server_address:$server_port"
  fi
}

# ------------------------------------------------------------------------------ commands
palpd_command=("$(program_path palpd "${server[palpd]:-}")")
[[ -z ${server[config]:-} ]] || palpd_command+=(--config "${server[config]}")
palpd_command+=(--port "$server_port")
array_value server_options server.0.options
palpd_command+=("${server_options[@]}")

probe_command=("$(program_path palp "${lab[palp]:-}")" probe "$(address_from localhost)"
  --duration 1 -q --name palp-lab-probe)

# observer_command N: the palpview command of observer N in the array observer_argv, its
# environment in observer_env.
observer_command() {
  local n=$1 host=${observer[$1.host]:-localhost} role=${observer[$1.role]:-observer}
  local name=${observer[$1.name]:-observer-$1}
  observer_env=("DISPLAY=${observer[$n.display]:-:0}")
  local extra_env
  array_value extra_env "observer.$n.env"
  observer_env+=("${extra_env[@]}")
  observer_argv=("$(program_path palpview "${observer[$n.palpview]:-}")"
    --connect "$(address_from "$host")" --name "$name")
  case $role in
    observer) observer_argv+=(--observer) ;;
    controller)
      observer_argv+=(--controller)
      local token=${observer[$n.token]:-${server[token]:-}}
      [[ -z $token ]] || observer_argv+=(--token "$token")
      ;;
    *) die_usage "$lab_file: observer $name: role must be observer or controller" ;;
  esac
  local key
  for key in camera preset width height; do
    [[ -z ${observer[$n.$key]:-} ]] || observer_argv+=("--$key" "${observer[$n.$key]}")
  done
  local options
  array_value options "observer.$n.options"
  observer_argv+=("${options[@]}")
}

# The command that runs ARGV on HOST in the background with its pid known: locally as is,
# remotely through ssh with "echo PALP_PID=$$; exec ..." so the remote pid is in the log.
launch_argv=()
launch_command() { # HOST ENV-ARRAY-NAME ARGV...
  local host=$1
  local -n env_words=$2
  shift 2
  local run=("$@")
  ((${#env_words[@]} == 0)) || run=(env "${env_words[@]}" "$@")
  if is_local "$host"; then
    launch_argv=("${run[@]}")
  else
    launch_argv=("${ssh_command[@]}" -n -- "$host" "echo PALP_PID=\$\$; exec $(quote_words "${run[@]}")")
  fi
}

# ------------------------------------------------------------------------------ dry run
# shellcheck disable=SC2034  # passed by name (launch_command's ENV-ARRAY-NAME)
no_env=()
if ((dry_run)); then
  echo "# lab $lab_file: palpd on $server_host (port $server_port), $observer_count observer(s)"
  if [[ $server_start == true ]]; then
    launch_command "$server_host" no_env "${palpd_command[@]}"
    echo "+ $(quote_words "${launch_argv[@]}")"
  fi
  echo "# until it answers (up to $wait_s s):"
  echo "+ $(quote_words "${probe_command[@]}")"
  for ((n = 1; n <= observer_count; n++)); do
    observer_command "$n"
    launch_command "${observer[$n.host]:-localhost}" observer_env "${observer_argv[@]}"
    echo "+ $(quote_words "${launch_argv[@]}")"
  done
  echo "# on Ctrl-C: SIGTERM to the observers, then to palpd (remote ones: ssh HOST kill -TERM PID)"
  exit 0
fi

# ------------------------------------------------------------------------------ run
if [[ -z $log_dir ]]; then
  log_dir=${lab[log_dir]:-${TMPDIR:-/tmp}/palp-lab-$(date +%Y%m%d-%H%M%S)-$$}
fi
mkdir -p "$log_dir"
echo "$program: logs in $log_dir"

declare -A pid_of=() host_of=() log_of=()
names=()

# start NAME HOST ENV-ARRAY-NAME ARGV...: runs the command in the background, logged.
start() {
  local name=$1 host=$2 env_name=$3
  shift 3
  launch_command "$host" "$env_name" "$@"
  local log="$log_dir/$name.log"
  echo "+ $(quote_words "${launch_argv[@]}")" >"$log"
  "${launch_argv[@]}" >>"$log" 2>&1 </dev/null &
  pid_of[$name]=$!
  host_of[$name]=$host
  log_of[$name]=$log
  names+=("$name")
  echo "$program: started $name (pid ${pid_of[$name]}${host:+ on $host}), log $log"
}

alive() { [[ -n ${pid_of[$1]:-} ]] && kill -0 "${pid_of[$1]}" 2>/dev/null; }

# stop NAME: SIGTERM (remotely by the pid it printed), then SIGKILL after 15 s.
stop() {
  local name=$1
  [[ -n ${pid_of[$name]:-} ]] || return 0
  local pid=${pid_of[$name]} host=${host_of[$name]}
  if ! is_local "$host"; then
    local remote_pid
    remote_pid=$(sed -n 's/^PALP_PID=\([0-9][0-9]*\)$/\1/p' "${log_of[$name]}" | head -n 1)
    if [[ -n $remote_pid ]]; then
      "${ssh_command[@]}" -n -- "$host" "kill -TERM $remote_pid" 2>/dev/null || true
    fi
  fi
  kill -TERM "$pid" 2>/dev/null || true
  local tenths
  for ((tenths = 0; tenths < 150; tenths++)); do
    alive "$name" || break
    sleep 0.1
  done
  if alive "$name"; then
    echo "$program: $name did not stop in 15 s: SIGKILL" >&2
    kill -KILL "$pid" 2>/dev/null || true
  fi
  wait "$pid" 2>/dev/null || true
  unset "pid_of[$name]"
}

stopping=0
stop_all() {
  ((stopping)) && return 0
  stopping=1
  local name
  for name in "${names[@]}"; do
    [[ $name == palpd ]] || stop "$name"
  done
  if [[ -n ${pid_of[palpd]:-} ]]; then
    stop palpd
    tail -n 1 "${log_of[palpd]}" | sed "s/^/$program: /"
  fi
  echo "$program: stopped; logs in $log_dir"
}
trap 'stop_all; exit 130' INT
trap 'stop_all; exit 143' TERM
trap 'stop_all' EXIT

# A server already answering on the port is not the one about to be started: the probe below
# could not tell them apart, and the new palpd would only find its port taken.
if [[ $server_start == true ]] && "${probe_command[@]}" >/dev/null 2>&1; then
  echo "$program: error: a server already answers at $(address_from localhost) before lab.sh" \
    "started palpd (another palpd?): stop it, or set another [server] port in $lab_file" >&2
  exit 1
fi
if [[ $server_start == true ]]; then
  start palpd "$server_host" no_env "${palpd_command[@]}"
fi

echo "$program: waiting for palpd at $(address_from localhost) (up to $wait_s s)"
deadline=$((SECONDS + wait_s))
until probe_output=$("${probe_command[@]}" 2>&1); do
  if [[ $server_start == true ]] && ! alive palpd; then
    echo "$program: error: palpd exited before answering; its log:" >&2
    tail -n 20 "${log_of[palpd]}" >&2
    exit 1
  fi
  if ((SECONDS >= deadline)); then
    echo "$program: error: palpd did not answer within $wait_s s; last probe:" >&2
    echo "$probe_output" >&2
    exit 1
  fi
  sleep 1
done
# The palpd lab.sh started must still run: one that found its port taken has exited, and what
# answered is another server.
if [[ $server_start == true ]] && ! alive palpd; then
  echo "$program: error: a server answers at $(address_from localhost) but it is not the palpd" \
    "lab.sh started, which exited; its log:" >&2
  tail -n 20 "${log_of[palpd]}" >&2
  exit 1
fi
echo "$program: palpd answers: ${probe_output##*$'\n'}"

for ((n = 1; n <= observer_count; n++)); do
  observer_command "$n"
  start "observer-${observer[$n.name]:-$n}" "${observer[$n.host]:-localhost}" observer_env \
    "${observer_argv[@]}"
done

echo "$program: running; Ctrl-C stops everything"
start_time=$SECONDS
declare -A reported=()
while true; do
  if [[ $server_start == true ]] && ! alive palpd; then
    status=0
    wait "${pid_of[palpd]}" || status=$?
    unset "pid_of[palpd]"
    echo "$program: palpd exited (status $status); stopping the observers" >&2
    tail -n 5 "${log_of[palpd]}" >&2
    stop_all
    exit $((status == 0 ? 0 : 1))
  fi
  for name in "${names[@]}"; do
    if [[ $name != palpd ]] && ! alive "$name" && [[ -z ${reported[$name]:-} ]]; then
      reported[$name]=1
      echo "$program: $name exited; the last lines of ${log_of[$name]}:" >&2
      tail -n 5 "${log_of[$name]}" >&2
    fi
  done
  if ((duration > 0 && SECONDS - start_time >= duration)); then
    echo "$program: --duration $duration s reached"
    stop_all
    exit 0
  fi
  sleep 1 &
  wait $! || true
done
