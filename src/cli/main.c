#include "dm_cli.h"

int main(int argc, char **argv) { return dm_cli_main(argc, argv); }
