// excite-config-rules: prints the rules of SessionConfig's numbers (field,
// default, range, why; server/service/config_rules.cc) as a Markdown table.
// docs/gen_api_reference.py puts it in docs/api-reference.md.

#include <cstdio>

#include "server/service/config_rules.h"

int main() {
  std::fputs(excite::service::NumberRulesMarkdown().c_str(), stdout);
  return 0;
}
