/* dm_cli — the `deltamap` command line. Parses arguments, calls the
 * library, prints tables or JSON. No physics here.
 *
 * Exit codes (also in `deltamap --help`): 0 success, 1 usage error,
 * 2 bad input (robot file, measured data, option value), 3 unreachable
 * pose, 4 numerical failure, 5 i/o error, 6 out of memory,
 * 7 interrupted. */
#ifndef DM_CLI_H
#define DM_CLI_H

int dm_cli_main(int argc, char **argv);

#endif
