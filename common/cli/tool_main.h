#pragma once
// The one way every command-line tool parses its arguments and reports failure: one line
// "TOOL: message" on stderr; exit 0 on success or --help, 2 for a bad command line, 1 for any
// error the work throws. Header-only: included by the tools, which link CLI11.

#include "common/system/budgets.h"
#include "common/system/error.h"

#include <CLI/CLI.hpp>

#include <exception>
#include <iostream>
#include <new>
#include <string>
#include <utility>
#include <vector>

namespace mrt {

/// What the tool is doing ("rendering scene.json"), named by run_tool's message when memory runs
/// out; each tool sets it at every stage of its work with set_activity.
inline std::string& current_activity() {
    static std::string activity;
    return activity;
}
inline void set_activity(std::string activity) {
    current_activity() = std::move(activity);
}

/// Parses argv into `app`, runs `validate()` (which may throw CLI::ValidationError for
/// combinations of options), then `work()`, whose return value is the exit code.
template <typename Validate, typename Work>
int run_tool(CLI::App& app, int argc, char** argv, Validate&& validate, Work&& work) {
    const std::string tool = app.get_name();
    try {
        app.parse(argc, argv);
        validate();
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) {  // --help
            return app.exit(e);
        }
        std::cerr << tool << ": " << e.what() << " (see --help)\n";
        return 2;
    }
    try {
        return work();
    } catch (const Error& e) {
        std::cerr << tool << ": " << e.what() << '\n';
    } catch (const std::bad_alloc&) {
        // Printed in pieces: nothing is allocated to say that allocating failed.
        const std::string& activity = current_activity();
        std::cerr << tool << ": out of memory" << (activity.empty() ? "" : " while ") << activity
                  << '\n';
    } catch (const std::exception& e) {
        std::cerr << tool << ": internal error: " << e.what() << '\n';
    }
    return 1;
}

/// Adds the repeatable `--budget NAME=VALUE` option, which raises (or lowers) one of `budgets`'
/// limits; a bad assignment is a command-line error.
inline void add_budget_option(CLI::App& app, Budgets& budgets) {
    app.add_option_function<std::vector<std::string>>(
           "--budget",
           [&budgets](const std::vector<std::string>& assignments) {
               for (const std::string& assignment : assignments) {
                   try {
                       set_budget(budgets, assignment);
                   } catch (const Error& e) {
                       throw CLI::ValidationError(e.what());
                   }
               }
           },
           budget_help())
        ->type_name("NAME=VALUE")
        ->take_all()
        ->allow_extra_args(false);
}

template <typename Work>
int run_tool(CLI::App& app, int argc, char** argv, Work&& work) {
    return run_tool(
        app, argc, argv, [] {}, std::forward<Work>(work));
}

}  // namespace mrt
