/* The CLI's main.c without its main(), for fuzz_http (which links the CLI files). */
int ffd_cli_main(int argc, char **argv);
#define main ffd_cli_main
#include "../tools/cli/main.c"
