"""Messaging shared by drone and ground: topics, message models, broker client, request/response."""
