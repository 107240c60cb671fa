// squall: the command-line client of squalld. `squall --help` lists the verbs.
#include "client/cli.h"

int main(int argc, char** argv) { return squall::cli::main(argc, argv); }
