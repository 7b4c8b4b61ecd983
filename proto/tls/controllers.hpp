// palpd's allow-list of controllers (--tls-controllers FILE): the certificate subjects that may
// be the CONTROLLER. Without it any certificate the --tls-client-ca verifies may; with it such a
// certificate whose subject is not listed may still observe.
//
// The file: one subject per line, in RFC 2253 form exactly as
//   openssl x509 -noout -subject -nameopt RFC2253 -in station-3.crt
// prints it (e.g. "subject=CN=station-3,O=palp lab"; the "subject=" is optional), compared
// whole and case-sensitively with the certificate's subject as palpd logs it. Blank lines and
// lines starting with '#' are skipped; spaces at either end of a line are dropped.
#pragma once

#include <string>
#include <vector>

namespace palp::tls {

// The subjects `text` lists; InputError (naming `file` and the line) for a line with control
// characters or longer than 1024 bytes, and for a list with no subject at all.
std::vector<std::string> parse_controller_subjects(const std::string& text,
                                                   const std::string& file);

// The same, read from `file` (ResourceError when it cannot be read; at most 1 MiB).
std::vector<std::string> read_controller_subjects(const std::string& file);

}  // namespace palp::tls
