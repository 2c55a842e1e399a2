"""On the machine: probing programs and the routes they take, their printouts read back, artifact cycles."""
