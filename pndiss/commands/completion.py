"""``pndiss completion bash|zsh|fish``: a shell completion script, made from the parser itself
(commands, their options, the choices of options like --profile, rule IDs for `pndiss rules`).

Install: ``pndiss completion bash > ~/.local/share/bash-completion/completions/pndiss``;
zsh: ``pndiss completion zsh > "${fpath[1]}/_pndiss"``; fish:
``pndiss completion fish > ~/.config/fish/completions/pndiss.fish``.
"""
from __future__ import annotations

import argparse


def add_parser(sub) -> None:
    p = sub.add_parser("completion", help="print a shell completion script (bash, zsh or fish)")
    p.add_argument("shell", choices=("bash", "zsh", "fish"))
    p.set_defaults(func=run)


def _spec() -> dict:
    """command -> (options, {option: choices}, positional choices)."""
    from ..cli import build_parser
    from ..rules import RULES
    parser = build_parser([])
    out = {}
    for a in parser._actions:
        if isinstance(a, argparse._SubParsersAction):
            for name, sp in a.choices.items():
                opts, choices, pos = [], {}, []
                for act in sp._actions:
                    if act.option_strings:
                        opts += act.option_strings
                        if act.choices:
                            for o in act.option_strings:
                                choices[o] = [str(c) for c in act.choices]
                    elif act.choices:
                        pos = [str(c) for c in act.choices]
                if name == "rules":
                    pos = sorted(RULES)
                out[name] = (opts, choices, pos)
    return out


def bash() -> str:
    spec = _spec()
    cases = []
    for cmd, (opts, choices, pos) in sorted(spec.items()):
        ch = "".join(f'            {o}) COMPREPLY=($(compgen -W "{" ".join(c)}" -- "$cur")); return;;\n'
                     for o, c in choices.items())
        cases.append(f'        {cmd})\n          case "$prev" in\n{ch}          esac\n'
                     f'          if [[ "$cur" == -* ]]; then COMPREPLY=($(compgen -W "{" ".join(opts)}" -- "$cur"));\n'
                     + (f'          else COMPREPLY=($(compgen -W "{" ".join(pos)}" -- "$cur"));\n' if pos else
                        '          else COMPREPLY=($(compgen -f -- "$cur"));\n')
                     + "          fi;;\n")
    return ("# bash completion for pndiss (pndiss completion bash)\n"
            "_pndiss() {\n  local cur prev cmd i\n  cur=\"${COMP_WORDS[COMP_CWORD]}\"; prev=\"${COMP_WORDS[COMP_CWORD-1]}\"\n"
            "  cmd=\"\"\n  for ((i=1; i<COMP_CWORD; i++)); do case \"${COMP_WORDS[i]}\" in -*) ;; *) cmd=\"${COMP_WORDS[i]}\"; break;; esac; done\n"
            f"  if [[ -z \"$cmd\" ]]; then COMPREPLY=($(compgen -W \"{' '.join(sorted(spec))} --version --debug --help\" -- \"$cur\")); return; fi\n"
            "  case \"$cmd\" in\n" + "".join(cases) + "  esac\n}\ncomplete -o filenames -F _pndiss pndiss\n")


def zsh() -> str:
    return ("#compdef pndiss\n# zsh completion for pndiss (pndiss completion zsh): the bash rules through bashcompinit\n"
            "autoload -U +X bashcompinit && bashcompinit\n" + bash())


def fish() -> str:
    spec = _spec()
    lines = ["# fish completion for pndiss (pndiss completion fish)", "complete -c pndiss -f"]
    for cmd in sorted(spec):
        lines.append(f"complete -c pndiss -n __fish_use_subcommand -a {cmd}")
    for cmd, (opts, choices, pos) in sorted(spec.items()):
        cond = f"'__fish_seen_subcommand_from {cmd}'"
        for o in opts:
            flag = f"-l {o[2:]}" if o.startswith("--") else f"-s {o[1:]}"
            ch = f" -xa '{' '.join(choices[o])}'" if o in choices else ""
            lines.append(f"complete -c pndiss -n {cond} {flag}{ch}")
        if pos:
            lines.append(f"complete -c pndiss -n {cond} -xa '{' '.join(pos)}'")
        else:
            lines.append(f"complete -c pndiss -n {cond} -F")
    return "\n".join(lines) + "\n"


def run(args) -> int:
    print({"bash": bash, "zsh": zsh, "fish": fish}[args.shell](), end="")
    return 0
