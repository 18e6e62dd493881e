# bash completion for kiln (installed as share/bash-completion/completions/kiln).
# tests/unit/cli_docs_test.py checks that every option of every verb's --help is here.

_kiln() {
  local cur prev verb i
  cur="${COMP_WORDS[COMP_CWORD]}"
  prev="${COMP_WORDS[COMP_CWORD-1]}"
  local verbs="build list inspect lint check-scene check-usage merge-usage diff-packs compile render test"
  local binding="-D --define --fvk-b-shift --fvk-t-shift --fvk-s-shift --fvk-u-shift --fvk-bind-globals --auto-bind --no-auto-bind --combined-image-samplers --separate-image-samplers"
  verb=""
  for ((i = 1; i < COMP_CWORD; i++)); do
    case "${COMP_WORDS[i]}" in
      -*) ;;
      *) verb="${COMP_WORDS[i]}"; break ;;
    esac
  done
  case "$prev" in
    --color) COMPREPLY=($(compgen -W "auto always never" -- "$cur")); return ;;
    --emit) COMPREPLY=($(compgen -W "variants preprocessed spvasm glsl msl reflection" -- "$cur")); return ;;
    --targets|--target) COMPREPLY=($(compgen -W "spirv glsl gles msl" -- "$cur")); return ;;
    -S|--stage) COMPREPLY=($(compgen -W "vertex fragment compute geometry hull domain vert frag comp geom tesc tese" -- "$cur")); return ;;
    -O) COMPREPLY=($(compgen -W "s 0" -- "$cur")); return ;;
    --format) COMPREPLY=($(compgen -W "text json sarif" -- "$cur")); return ;;
    --frontend) COMPREPLY=($(compgen -W "glslang" -- "$cur")); return ;;
    --optimize) COMPREPLY=($(compgen -W "kiln O" -- "$cur")); return ;;
    --api|--against) COMPREPLY=($(compgen -W "vulkan gl gles" -- "$cur")); return ;;
    --scene|--usage) COMPREPLY=($(compgen -f -X '!*.json' -- "$cur")); compopt -o plusdirs 2>/dev/null; return ;;
    -o|--output|--cache|--extract|--depfile|--summary-json|--sarif-root|-I|--include-dir|--golden|--report|--exr)
      COMPREPLY=($(compgen -f -- "$cur")); compopt -o filenames 2>/dev/null; return ;;
  esac
  if [[ -z "$verb" ]]; then
    if [[ "$cur" == -* ]]; then
      COMPREPLY=($(compgen -W "--help --version --color" -- "$cur"))
    else
      COMPREPLY=($(compgen -W "$verbs" -- "$cur"))
    fi
    return
  fi
  local options="--help --color"
  case "$verb" in
    build) options+=" --output -o --scene $binding --jobs -j --cache --no-cache --cache-max-mb --emit --depfile --targets
                     --frontend --optimize --worker-timeout --quiet -q --summary-json --remote --remote-upload --remote-required
                     --remote-instance --remote-namespace --remote-connect-timeout --remote-timeout --remote-transfers --shard
                     --usage --usage-tag --usage-margin" ;;
    list) options+=" --scene $binding --json" ;;
    inspect) options+=" --json --extract" ;;
    lint) options+=" --cache --no-cache --scene $binding --include-dir -I --format --output -o --sarif-root --werror" ;;
    check-scene|diff-packs) options+=" --json" ;;
    check-usage) options+=" --usage-tag" ;;
    merge-usage) options+=" --output -o --usage-tag --pass" ;;
    compile) options+=" --stage -S --entry -E --output -o --target --include-dir -I $binding -O -g --depfile --werror" ;;
    render) options+=" --variant --scene --output -o --exr --size --api" ;;
    test) options+=" --scene --golden --tolerances --report --filter --shard --cover --usage-log --api --against" ;;
  esac
  if [[ "$cur" == -* ]]; then
    COMPREPLY=($(compgen -W "$options" -- "$cur"))
  else
    COMPREPLY=($(compgen -f -- "$cur"))
    compopt -o filenames 2>/dev/null
  fi
}
complete -F _kiln kiln
