# Bash completion for `sirupp` and the sirupp-* processes, read from their generated --help
# (docs/command-line.md): commands and subcommands after `sirupp`, flags after "-".
#   source scripts/sirupp-completion.bash      (or copy it to /etc/bash_completion.d/)

_sirupp_help_words() {  # $1: what to list (commands or flags), then the command line to ask
  local kind=$1
  shift
  local help
  help=$("$@" --help 2>/dev/null) || return
  if [[ $kind == flags ]]; then
    grep -oE -- '--[a-z][a-z0-9-]*' <<<"$help" | sort -u
  else
    awk '/^Commands:/ {on = 1; next} on && /^  [a-z]/ {print $1} on && /^$/ {on = 0}' <<<"$help"
  fi
}

_sirupp() {
  local cur=${COMP_WORDS[COMP_CWORD]}
  local asked=("${COMP_WORDS[0]}") word
  for word in "${COMP_WORDS[@]:1:COMP_CWORD-1}"; do  # the command words typed so far
    [[ $word == -* ]] && break
    asked+=("$word")
  done
  local kind=commands
  [[ $cur == -* ]] && kind=flags
  mapfile -t COMPREPLY < <(compgen -W "$(_sirupp_help_words "$kind" "${asked[@]}")" -- "$cur")
}

complete -o default -F _sirupp sirupp sirupp-sim sirupp-control sirupp-hardware \
  sirupp-picservo-emu sirupp-logger sirupp-viewer sirupp-panel
