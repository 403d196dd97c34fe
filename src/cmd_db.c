/* cmd_db.c -- `raytraffic db` (not yet implemented). */
#include "cmd.h"

#include <stdio.h>
#include <string.h>

int main_db(int argc, char **argv)
{
    if (argc > 1 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
        printf("Usage: raytraffic db (not yet implemented)\n");
        return RT_EXIT_OK;
    }
    rt_cmd_error("db", "not yet implemented");
    return RT_EXIT_FAIL;
}
