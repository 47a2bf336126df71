/* cli_methods — the registry of the methods' own commands (`ffd pbffd`,
 * `ffd tspline`, ...): one line per command. Each is described (name, its
 * lines of the top-level help, handler) in the method's tools/cli/cmd_<method>.c;
 * main.c builds its dispatch, its help and its messages from this list and
 * names no method. Adding a method's command: its cmd_<method>.c and one line
 * here (docs/architecture.md, "Adding a method"). */
#include "cli.h"

extern const cli_command cli_command_pbffd;
extern const cli_command cli_command_tspline;

static const cli_command *const commands[] = {
    &cli_command_pbffd,
    &cli_command_tspline,
};

size_t cli_method_command_count(void)
{
    return sizeof commands / sizeof commands[0];
}

const cli_command *cli_method_command_at(size_t i)
{
    return i < cli_method_command_count() ? commands[i] : NULL;
}
