# Sourced by the tool scripts after they define usage(): answers -h/--help with
# the usage (exit 0) and refuses any argument not in the allowed list (exit 2).
#   tool_args "ALLOWED ARGS" "$@"     e.g. tool_args "" "$@", tool_args "--sanitize" "$@"
tool_args() {
  local allowed=" $1 "
  shift
  for a in "$@"; do
    case "$a" in
      -h | --help) usage; exit 0 ;;
    esac
    if [[ "$allowed" != *" $a "* ]]; then
      echo "$(basename "$0"): unknown argument '$a'" >&2
      usage >&2
      exit 2
    fi
  done
}
