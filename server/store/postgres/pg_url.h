// Naming a PostgreSQL URL in logs and errors without its password.
#ifndef IMPOSTOR_SERVER_STORE_POSTGRES_PG_URL_H_
#define IMPOSTOR_SERVER_STORE_POSTGRES_PG_URL_H_

#include <string>

namespace impostor {

// `url` with the password of its user-info part ("user:secret@") and any
// `password=` query parameter replaced by "***". Safe to log.
std::string RedactDatabaseUrl(const std::string& url);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_POSTGRES_PG_URL_H_
